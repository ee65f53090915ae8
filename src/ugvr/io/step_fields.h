// A time step's fields read without its mesh: what the exact engine's step switch reads when the step's mesh is the
// one it already holds (docs/time-series.md, "Fields-only step reads").
//
// Which steps qualify:
//   Exodus II     every step: the format has no time axis on coordinates or connectivity (static by format). The
//                 file is opened once (ExodusFieldReader keeps it open, with its block layout) and a step reads its
//                 variables' records at that time index only (nc_get_vara), nothing of the mesh.
//   .vtu files    (the steps of a .pvd, a .series, a numbered series) a step whose files' stored geometry keys equal
//                 those of the files the mesh was read from. The key (vtu_geometry_key) is a hash of what decides
//                 the mesh as stored: the file's encoding (byte order, header word, compressor), each <Piece>'s
//                 NumberOfPoints / NumberOfCells, and for the Points and the connectivity, offsets and types arrays
//                 their type, components, format and stored bytes (the element text, or the appended header and raw
//                 bytes, compressed or not) hashed as they lie in the file, never decoded. Equal keys decode to the
//                 same mesh (up to a 64-bit hash collision, as for geometry_fingerprint); a moved point, another
//                 connectivity, other counts or another encoding give another key, and the step is then read whole
//                 and compared by geometry_fingerprint as before (a moving mesh rebuilds the walk mesh).
//   .pvtu files   the same, by a key combining the piece count and each piece file's key in piece order (the whole
//                 read concatenates the pieces in that order); the fields are read piece by piece and concatenated as
//                 the whole read does. One piece without a key makes the .pvtu's step one without.
//   .vtk files    (legacy VTK, the steps of a .pvd, a .series, a numbered series) the same, by vtk_legacy_geometry_key:
//                 a hash of the version line and of everything from the ASCII/BINARY word to the first POINT_DATA /
//                 CELL_DATA as stored (the DATASET line, POINTS, CELLS / OFFSETS / CONNECTIVITY, CELL_TYPES; for
//                 structured types DIMENSIONS, POINTS, ORIGIN, SPACING, the coordinates), less the title line and
//                 dataset-level FIELD and METADATA blocks (a writer's TIME). Every dataset type the reader reads is
//                 keyed. The fields-only read passes over POINTS and the cell lists (a seek in BINARY files, the words
//                 counted unparsed in ASCII ones) and reads CELL_TYPES for the cells whose values the mesh keeps.
//   OpenFOAM      a step whose time directory holds no polyMesh/points nor polyMesh/faces (in no processor directory
//                 of a decomposed case): it has the case's constant mesh. Its key (openfoam_mesh_key) hashes the
//                 pieces' directories and their constant/polyMesh files' names, sizes and modification times (not their
//                 bytes: that would cost the read it saves); a mesh file rewritten to the same size within the time
//                 stamp granularity keeps its key. A step whose time directory moves the mesh has no key: read whole.
//                 The fields-only read needs the layout of the mesh's whole read (OpenFoamLayout: the pieces' cell and
//                 point counts, the polyhedra decomposition's cell order and centre points, the cellZone field, the
//                 notes): read_whole keeps it; a read() without it (or with another mesh's) reads its step whole once
//                 and keeps that step's layout. Then it lists the time directory and decodes its field files through
//                 the reader's own code, never opening constant/polyMesh.
//   EnSight       a .case whose geometry ("model:") has no '*' wildcards and no file set (or no time set): one geometry
//                 for all steps. Its key (ensight_mesh_key) hashes the geometry file's path, size and modification
//                 time. The layout (EnsightLayout: each part's counts, element sections, polyhedra decomposition, the
//                 geometry's encoding and notes) is kept by read_whole as for OpenFOAM; the fields-only read parses the
//                 .case and reads each variable's file with the whole read's code against a mesh-less skeleton of the
//                 parts, never opening the geometry file. A geometry per step (wildcards, a file set) and a .sos:
//                 whole.
//   PLOT3D        (a grid file and a .q file per step) a step whose grid file is the one read: its key
//                 (plot3d_mesh_key) hashes the grid file's path, size and modification time. The layout
//                 (Plot3dLayout: the byte order, records, blocking, precision, IBLANK and block dimensions detected
//                 from the grid) is kept by read_whole as for OpenFOAM; the fields-only read checks and decodes the
//                 step's .q file with the whole read's code (plan_q, read_solution), never opening the grid file. A
//                 tiny grid whose layout only the solution file could decide keeps no layout: its steps read whole.
//   CGNS          (steps by FlowSolutionPointers) a file none of whose zones' grids move (one GridCoordinates_t, no
//                 RigidGridMotion / ArbitraryGridMotion, no GridCoordinatesPointers): its key (cgns_mesh_key) hashes
//                 the file's path, size and modification time. The layout (CgnsLayout: each zone's location, the shape
//                 its solutions are read with, the polyhedra decomposition's CellExpansion, the mesh's notes) is kept
//                 by read_whole; the fields-only read reads each zone's solutions with the whole read's code
//                 (zone_fields: read_solutions, the same expansion), no coordinates nor element sections.
//   Files with appended base64 data (whose stored length the header does not give) and other formats have no key:
//   their steps are read whole.
// A file that shrinks while its key is hashed is an error naming it and the offset (io/byte_hash.h), which ends the
// switch as a whole read of the damaged file would; nothing is cached for it.
// A fields-only read decodes every PointData / CellData array (or Exodus variable) of the step and nothing else, so
// the dataset it completes is the full read's, field for field and bit for bit.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/grid/dataset.h"
#include "ugvr/io/time_series.h"

namespace ugvr {

// The stored geometry key of a .vtu (UnstructuredGrid) file, as above; nullopt for other files and for appended base64
// data. Reads the markup and the geometry arrays' stored bytes. Throws ugvr::Error naming the file for bad markup.
std::optional<uint64_t> vtu_geometry_key(const std::string& path);

// The stored geometry key of a .pvtu (PUnstructuredGrid) file: its piece count and its piece files' vtu_geometry_key,
// in piece order; nullopt for other files and when a piece has no key. Reads the .pvtu's markup and each piece's as
// vtu_geometry_key does. Throws ugvr::Error naming the file (bad markup, a missing or repeated piece).
std::optional<uint64_t> pvtu_geometry_key(const std::string& path);

// Every field of a .vtu file as read_dataset gives them (cell data restricted to the volume cells the mesh keeps),
// without reading its points or connectivity (the types array is read when cells are dropped). Skipped arrays are
// warned about in `warnings`, as the full read does.
FieldSet read_vtu_fields(const std::string& path, std::vector<std::string>& warnings);
// The same for a .pvtu: its pieces' fields concatenated in piece order, bit for bit those of read_dataset (its checks
// of the fields the pieces share and the .pvtu declares included); `sources` gets the .pvtu and its pieces, as the
// whole read names them.
FieldSet read_pvtu_fields(const std::string& path, std::vector<std::string>& sources,
                          std::vector<std::string>& warnings);

// The stored geometry key of a legacy VTK (.vtk) file, as above; nullopt for other extensions. Reads the header and
// hashes the geometry sections' stored bytes (ASCII ones are scanned word by word, not parsed). Throws ugvr::Error
// naming the file for a bad header or a section that runs past the end, and naming the file and offset for a file
// that shrinks while hashed.
std::optional<uint64_t> vtk_legacy_geometry_key(const std::string& path);
// Every POINT_DATA / CELL_DATA field of a legacy VTK file as read_dataset gives them (the same checks; cell data
// restricted to the volume cells the mesh keeps), without reading its points or cell lists (its CELL_TYPES are read).
// `format` is set as the whole read sets Dataset::format; the reader's warnings about fields (skipped string arrays,
// a repeated name, dataset-level FIELD data) go to `warnings`, those about the mesh's cells do not.
FieldSet read_vtk_legacy_fields(const std::string& path, std::string& format, std::vector<std::string>& warnings);

// An Exodus II file opened once for its steps' fields: its dimensions and element-block layout are read here (not the
// coordinates or the connectivity), then each read() reads one time index's variables. Not thread-safe (netCDF is
// not): StepFieldReader serialises it.
class ExodusFieldReader {
 public:
  explicit ExodusFieldReader(const std::string& path);
  ~ExodusFieldReader();
  ExodusFieldReader(const ExodusFieldReader&) = delete;
  ExodusFieldReader& operator=(const ExodusFieldReader&) = delete;

  // The fields of time index `step` (block_id, nodal and element variables, as read_exodus gives them); `format` is
  // set as read_exodus sets Dataset::format. Throws ugvr::Error naming the file for a step out of range.
  FieldSet read(uint64_t step, std::string& format, std::vector<std::string>& warnings);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// What a fields-only read of a step gives: the dataset read_time_step would, less its grids.
struct StepFields {
  std::vector<FieldSet> blocks;  // in read_time_step's block order
  std::string format;
  std::vector<std::string> sources;
  std::vector<std::string> warnings;
};

struct OpenFoamLayout;
struct EnsightLayout;
struct Plot3dLayout;
struct CgnsLayout;

// The fields-only reads of one series. Thread-safe: a scene's prefetch thread and its own share one.
class StepFieldReader {
 public:
  explicit StepFieldReader(std::shared_ptr<const TimeSeries> series);
  ~StepFieldReader();

  // Whether every step has the first step's mesh by the format and a fields-only read (Exodus).
  bool static_by_format() const;
  // Step `step` read whole, as read_time_step reads it; an OpenFOAM step with the constant mesh (an EnSight step of a
  // case with one geometry, a PLOT3D step, a CGNS step of a static mesh) keeps the mesh's layout for later fields-only
  // reads (so read the mesh step shown here).
  Dataset read_whole(size_t step);
  // One stored geometry key per file of step `step` when every file has one (.vtu, .pvtu, .vtk; OpenFOAM: one key, the
  // constant mesh's; EnSight: one key, the static geometry file's; PLOT3D: one key, the grid file's; CGNS: one key, the
  // file's when no grid moves); nullopt otherwise (read the step whole). Equal key lists: the same mesh. A .vtu's key
  // (a .pvtu's pieces' keys) is computed once while its size and modification time stay those seen then (a range pass,
  // then the step switches, visit every file again); a file rewritten to the same size within the file system's time
  // stamp granularity (a few milliseconds) would keep its old key. A .pvtu's piece list is read again each time (its
  // markup only). Throws ugvr::Error naming the file when a file cannot be read (bad markup, truncated while hashed).
  std::optional<std::vector<uint64_t>> geometry_keys(size_t step) const;
  // Whether step `step` has step `mesh_step`'s mesh as stored: by the format (Exodus) or by equal geometry keys (.vtu,
  // .pvtu, .vtk, OpenFOAM, EnSight, PLOT3D, CGNS).
  // Then read(step) completes a dataset of mesh_step's grids. False where only a whole read could tell.
  bool has_mesh_of(size_t step, size_t mesh_step) const;
  // Step `step`'s fields; valid where static_by_format() or geometry_keys() says the step has a fields-only read.
  StepFields read(size_t step);
  // Step `step`'s fields for a pass over its values alone (the global colour range of `ugvr render --time all`),
  // `mesh_step` being a step whose mesh is held: read fields-only where has_mesh_of(step, mesh_step), nothing of the
  // step's mesh read; else (a changing mesh, a format without a fields-only read) read whole and its grids dropped.
  StepFields read_values(size_t step, size_t mesh_step);

 private:
  struct CachedKey {
    uintmax_t size = 0;
    std::filesystem::file_time_type mtime;
    std::optional<uint64_t> key;
  };
  std::optional<uint64_t> cached_geometry_key(const std::string& path) const;
  // A file's key by `key_of` (vtu_geometry_key, vtk_legacy_geometry_key, cgns_mesh_key), cached by size and
  // modification time.
  using FileKey = std::optional<uint64_t> (*)(const std::string&);
  std::optional<uint64_t> cached_file_key(const std::string& path, FileKey key_of) const;
  // An OpenFOAM step's fields on the kept layout (read whole, keeping its layout, where none of its mesh is kept).
  StepFields read_openfoam_step(size_t step);
  // The same for an EnSight step on the kept geometry layout.
  StepFields read_ensight_step(size_t step);
  // The same for a PLOT3D step (its .q file) on the kept grid layout.
  StepFields read_plot3d_step(size_t step);
  // The same for a CGNS step (its FlowSolution) on the kept mesh layout.
  StepFields read_cgns_step(size_t step);

  std::shared_ptr<const TimeSeries> series_;
  std::mutex exodus_mutex_;
  std::unique_ptr<ExodusFieldReader> exodus_;  // opened on the first read
  // A kept layout, read or replaced under layout_mutex_ (a scene's prefetch thread and its own share the reader).
  template <class Layout>
  std::shared_ptr<const Layout> kept_layout(const std::shared_ptr<const Layout>& slot) {
    std::lock_guard lock(layout_mutex_);
    return slot;
  }
  template <class Layout>
  void keep_layout(std::shared_ptr<const Layout>& slot, std::shared_ptr<const Layout> layout) {
    std::lock_guard lock(layout_mutex_);
    slot = std::move(layout);
  }
  std::mutex layout_mutex_;
  std::shared_ptr<const OpenFoamLayout> foam_layout_;    // of the last constant mesh read whole (read_whole)
  std::shared_ptr<const EnsightLayout> ensight_layout_;  // of the last static geometry read whole (read_whole)
  std::shared_ptr<const Plot3dLayout> plot3d_layout_;    // of the last PLOT3D grid read whole (read_whole)
  std::shared_ptr<const CgnsLayout> cgns_layout_;        // of the last static CGNS mesh read whole (read_whole)
  mutable std::mutex keys_mutex_;
  mutable std::map<std::string, CachedKey> keys_;  // by file path, see geometry_keys
};

// What read_time_step appends to a file's format for a series' step: ", time step 3 of 24 (t = 0.125) of wake.pvd".
std::string series_step_label(const TimeSeries& series, size_t step);

// The dataset of a fields-only step: `fields` on the grids (and block names) of `mesh`, a dataset of the same mesh:
// copied, or moved out of a dataset nobody needs any more. Throws ugvr::Error when the block counts differ.
Dataset with_grids_of(const Dataset& mesh, StepFields fields);
Dataset with_grids_of(Dataset&& mesh, StepFields fields);

}  // namespace ugvr
