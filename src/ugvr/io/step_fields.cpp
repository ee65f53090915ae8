#include "ugvr/io/step_fields.h"

#include <functional>
#include <utility>

#include "ugvr/core/error.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/cgns_fields.h"
#include "ugvr/io/ensight_fields.h"
#include "ugvr/io/openfoam_reader.h"
#include "ugvr/io/plot3d_fields.h"
#include "ugvr/io/pvtu_pieces.h"

namespace ugvr {

namespace {

// Series whose steps are one dataset file each (a .pvd step may have several: its parts, one block each).
bool steps_are_files(SeriesKind kind) {
  return kind == SeriesKind::Pvd || kind == SeriesKind::SeriesJson || kind == SeriesKind::Numbered;
}

void check_blocks(const Dataset& mesh, const StepFields& fields) {
  if (mesh.blocks.size() != fields.blocks.size())
    fail_in(fields.sources.empty() ? std::string("time step") : fields.sources[0],
            "the step has " + std::to_string(fields.blocks.size()) + " blocks, the mesh it was read for " +
                std::to_string(mesh.blocks.size()));
}

// A .pvtu's key from its pieces' (`piece_key`: vtu_geometry_key, or the reader's cached one). Seeded apart from the
// .vtu keys, so that a .pvtu of one piece and that piece alone (the same mesh) are told apart only by the fingerprint
// of a whole read, never mistaken for each other's files.
std::optional<uint64_t> combined_pvtu_key(const std::string& path,
                                          const std::function<std::optional<uint64_t>(const std::string&)>& piece_key) {
  if (!is_pvtu_path(path)) return std::nullopt;
  const std::vector<std::string> pieces = pvtu_piece_files(path);
  uint64_t h = hash_mix(hash_mix(kFnvOffset, 0x70767475), pieces.size());  // "pvtu"
  for (const std::string& piece : pieces) {
    const std::optional<uint64_t> key = piece_key(piece);
    if (!key) return std::nullopt;
    h = hash_mix(h, *key);
  }
  return h;
}

bool is_legacy_vtk_path(const std::string& path) { return extension_lower(path) == ".vtk"; }

// The key of one dataset file (not a .pvtu): .vtk files by the legacy reader, the others as .vtu files (nullopt for
// other formats).
std::optional<uint64_t> file_geometry_key(const std::string& path) {
  return is_legacy_vtk_path(path) ? vtk_legacy_geometry_key(path) : vtu_geometry_key(path);
}

StepFields fields_of(Dataset whole) {
  StepFields out;
  for (Block& b : whole.blocks) out.blocks.push_back(std::move(b.fields));
  out.format = std::move(whole.format);
  out.sources = std::move(whole.sources);
  out.warnings = std::move(whole.warnings);
  return out;
}

Dataset without_grids(StepFields fields) {
  Dataset ds;
  ds.format = std::move(fields.format);
  ds.sources = std::move(fields.sources);
  ds.warnings = std::move(fields.warnings);
  for (FieldSet& f : fields.blocks) ds.blocks.push_back(Block{{}, {}, std::move(f)});
  return ds;
}

}  // namespace

std::optional<uint64_t> pvtu_geometry_key(const std::string& path) {
  return combined_pvtu_key(path, [](const std::string& piece) { return vtu_geometry_key(piece); });
}

StepFieldReader::StepFieldReader(std::shared_ptr<const TimeSeries> series) : series_(std::move(series)) {}
StepFieldReader::~StepFieldReader() = default;

bool StepFieldReader::static_by_format() const { return series_->kind == SeriesKind::Exodus; }

std::optional<uint64_t> StepFieldReader::cached_file_key(const std::string& path, FileKey key_of) const {
  std::error_code size_error, time_error;
  const uintmax_t size = std::filesystem::file_size(path, size_error);
  const std::filesystem::file_time_type mtime = std::filesystem::last_write_time(path, time_error);
  // A file that cannot be stat'ed is not cached: the key's read names it in its error.
  if (size_error || time_error) return key_of(path);
  {
    std::lock_guard lock(keys_mutex_);
    const auto it = keys_.find(path);
    if (it != keys_.end() && it->second.size == size && it->second.mtime == mtime) return it->second.key;
  }
  // Computed unlocked (it reads the geometry's stored bytes): two threads may both compute one file's key, the same.
  const std::optional<uint64_t> key = key_of(path);
  std::lock_guard lock(keys_mutex_);
  keys_[path] = CachedKey{size, mtime, key};
  return key;
}

std::optional<uint64_t> StepFieldReader::cached_geometry_key(const std::string& path) const {
  if (is_pvtu_path(path))
    return combined_pvtu_key(path,
                             [this](const std::string& piece) { return cached_file_key(piece, file_geometry_key); });
  return cached_file_key(path, file_geometry_key);
}

Dataset StepFieldReader::read_whole(size_t step) {
  if (step >= series_->size()) return read_time_step(*series_, step);  // its error names the step count
  // As read_time_step reads a multi-step file's step (read_dataset: the reader, its step), the layout kept besides.
  const TimeStep& st = series_->steps[step];
  if (series_->kind == SeriesKind::OpenFoam) {
    std::shared_ptr<const OpenFoamLayout> layout;
    Dataset ds = read_openfoam(st.files[0], st.reader_step, &layout);
    if (openfoam_layout_mesh_key(*layout)) keep_layout(foam_layout_, std::move(layout));
    return ds;
  }
  if (series_->kind == SeriesKind::EnSight) {
    std::shared_ptr<const EnsightLayout> layout;  // none for a .sos
    Dataset ds = read_ensight(st.files[0], st.reader_step, &layout);
    if (layout && ensight_layout_mesh_key(*layout)) keep_layout(ensight_layout_, std::move(layout));
    return ds;
  }
  if (series_->kind == SeriesKind::Cgns) {
    std::shared_ptr<const CgnsLayout> layout;
    Dataset ds = read_cgns(st.files[0], st.reader_step, &layout);
    if (cgns_layout_mesh_key(*layout)) keep_layout(cgns_layout_, std::move(layout));
    return ds;
  }
  if (series_->kind == SeriesKind::Plot3d) {
    std::shared_ptr<const Plot3dLayout> layout;
    Dataset ds = read_plot3d(st.files[0], st.files[1], &layout);
    ds.format += series_step_label(*series_, step);
    if (plot3d_layout_mesh_key(*layout)) keep_layout(plot3d_layout_, std::move(layout));
    return ds;
  }
  return read_time_step(*series_, step);
}

std::optional<std::vector<uint64_t>> StepFieldReader::geometry_keys(size_t step) const {
  if ((series_->kind == SeriesKind::OpenFoam || series_->kind == SeriesKind::EnSight) && step < series_->size()) {
    const TimeStep& st = series_->steps[step];
    const std::optional<uint64_t> key = series_->kind == SeriesKind::OpenFoam
                                            ? openfoam_mesh_key(st.files[0], st.reader_step)
                                            : ensight_mesh_key(st.files[0]);
    if (!key) return std::nullopt;
    return std::vector<uint64_t>{*key};
  }
  if (series_->kind == SeriesKind::Plot3d && step < series_->size())
    return std::vector<uint64_t>{plot3d_mesh_key(series_->steps[step].files[0])};
  if (series_->kind == SeriesKind::Cgns && step < series_->size()) {
    // Cached: the key opens the file (libcgns reads its node tree), which costs as much as a small step's solution.
    const std::optional<uint64_t> key = cached_file_key(series_->steps[step].files[0], cgns_mesh_key);
    if (!key) return std::nullopt;
    return std::vector<uint64_t>{*key};
  }
  if (!steps_are_files(series_->kind) || step >= series_->size()) return std::nullopt;
  std::vector<uint64_t> keys;
  for (const std::string& file : series_->steps[step].files) {
    const std::optional<uint64_t> key = cached_geometry_key(file);
    if (!key) return std::nullopt;
    keys.push_back(*key);
  }
  return keys;
}

StepFields StepFieldReader::read(size_t step) {
  const size_t n = series_->size();
  if (step >= n)
    fail_in(series_->source, "time step " + std::to_string(step) + " does not exist: the series has " +
                                 std::to_string(n) + " step" + (n == 1 ? "" : "s") + " (0.." + std::to_string(n - 1) +
                                 ")");
  const TimeStep& st = series_->steps[step];
  StepFields out;
  if (static_by_format()) {
    // netCDF is not thread-safe, and the file stays open across steps.
    std::lock_guard lock(exodus_mutex_);
    if (!exodus_) exodus_ = std::make_unique<ExodusFieldReader>(st.files[0]);
    out.blocks.push_back(exodus_->read(uint64_t(st.reader_step), out.format, out.warnings));
    out.sources.push_back(st.files[0]);
    return out;
  }
  if (series_->kind == SeriesKind::OpenFoam) return read_openfoam_step(step);
  if (series_->kind == SeriesKind::EnSight) return read_ensight_step(step);
  if (series_->kind == SeriesKind::Plot3d) return read_plot3d_step(step);
  if (series_->kind == SeriesKind::Cgns) return read_cgns_step(step);
  if (!steps_are_files(series_->kind))
    fail_in(series_->source, "time step " + std::to_string(step) + " has no fields-only read (read it whole)");
  std::string legacy_format;  // a .vtk's, as its whole read gives it
  for (const std::string& file : st.files) {
    if (is_pvtu_path(file)) {
      out.blocks.push_back(read_pvtu_fields(file, out.sources, out.warnings));
    } else if (is_legacy_vtk_path(file)) {
      std::string format;
      out.blocks.push_back(read_vtk_legacy_fields(file, format, out.warnings));
      out.sources.push_back(file);
      if (legacy_format.empty()) legacy_format = std::move(format);
    } else {
      out.blocks.push_back(read_vtu_fields(file, out.warnings));
      out.sources.push_back(file);
    }
  }
  // The whole read's: the first file's format (the parts of a .pvd step are read as one dataset each).
  const std::string& first = st.files[0];
  out.format = (is_legacy_vtk_path(first) ? legacy_format
                : is_pvtu_path(first)     ? std::string("VTK XML PUnstructuredGrid (.pvtu)")
                                          : std::string("VTK XML UnstructuredGrid (.vtu)")) +
               series_step_label(*series_, step);
  return out;
}

StepFields StepFieldReader::read_openfoam_step(size_t step) {
  const TimeStep& st = series_->steps[step];
  const std::optional<uint64_t> key = openfoam_mesh_key(st.files[0], st.reader_step);
  if (!key)
    fail_in(series_->source, "time step " + std::to_string(step) +
                                 " moves the mesh (its time directory has a polyMesh): no fields-only read");
  const std::shared_ptr<const OpenFoamLayout> layout = kept_layout(foam_layout_);
  // No layout of this mesh kept yet (its step was not read through read_whole, or the mesh files changed since): this
  // step read whole keeps one.
  if (!layout || openfoam_layout_mesh_key(*layout) != key) return fields_of(read_whole(step));
  StepFields out;
  out.blocks.push_back(
      read_openfoam_fields(*layout, st.files[0], st.reader_step, out.format, out.sources, out.warnings));
  return out;
}

StepFields StepFieldReader::read_ensight_step(size_t step) {
  const TimeStep& st = series_->steps[step];
  const std::optional<uint64_t> key = ensight_mesh_key(st.files[0]);
  if (!key)
    fail_in(series_->source,
            "time step " + std::to_string(step) +
                ": the geometry changes per step (a file per step or a file set): no fields-only read");
  const std::shared_ptr<const EnsightLayout> layout = kept_layout(ensight_layout_);
  // No layout of this geometry kept yet, or the geometry file changed since: this step read whole keeps one.
  if (!layout || ensight_layout_mesh_key(*layout) != key) return fields_of(read_whole(step));
  StepFields out;
  out.blocks = read_ensight_fields(*layout, st.files[0], st.reader_step, out.format, out.sources, out.warnings);
  return out;
}

StepFields StepFieldReader::read_plot3d_step(size_t step) {
  const TimeStep& st = series_->steps[step];
  const uint64_t key = plot3d_mesh_key(st.files[0]);
  const std::shared_ptr<const Plot3dLayout> layout = kept_layout(plot3d_layout_);
  // No layout of this grid kept yet, or the grid file changed since: this step read whole keeps one.
  if (!layout || plot3d_layout_mesh_key(*layout) != key) return fields_of(read_whole(step));
  StepFields out;
  out.blocks = read_plot3d_fields(*layout, st.files[1], out.format, out.sources, out.warnings);
  out.format += series_step_label(*series_, step);
  return out;
}

StepFields StepFieldReader::read_cgns_step(size_t step) {
  const TimeStep& st = series_->steps[step];
  const std::optional<std::vector<uint64_t>> keys = geometry_keys(step);
  const std::optional<uint64_t> key = keys ? std::optional<uint64_t>(keys->front()) : std::nullopt;
  if (!key)
    fail_in(series_->source, "time step " + std::to_string(step) +
                                 ": a zone's grid moves (grid motion or GridCoordinatesPointers): no fields-only read");
  const std::shared_ptr<const CgnsLayout> layout = kept_layout(cgns_layout_);
  // No layout of this mesh kept yet, or the file changed since: this step read whole keeps one.
  if (!layout || cgns_layout_mesh_key(*layout) != key) return fields_of(read_whole(step));
  StepFields out;
  out.blocks = read_cgns_fields(*layout, st.files[0], st.reader_step, out.format, out.sources, out.warnings);
  return out;
}

bool StepFieldReader::has_mesh_of(size_t step, size_t mesh_step) const {
  if (static_by_format()) return true;
  const std::optional<std::vector<uint64_t>> keys = geometry_keys(step);
  return keys && keys == geometry_keys(mesh_step);
}

StepFields StepFieldReader::read_values(size_t step, size_t mesh_step) {
  if (has_mesh_of(step, mesh_step)) return read(step);
  return fields_of(read_time_step(*series_, step));
}

Dataset with_grids_of(const Dataset& mesh, StepFields fields) {
  check_blocks(mesh, fields);
  Dataset ds = without_grids(std::move(fields));
  for (size_t b = 0; b < ds.blocks.size(); ++b) {
    ds.blocks[b].name = mesh.blocks[b].name;
    ds.blocks[b].grid = mesh.blocks[b].grid;
  }
  return ds;
}

Dataset with_grids_of(Dataset&& mesh, StepFields fields) {
  check_blocks(mesh, fields);
  Dataset ds = without_grids(std::move(fields));
  for (size_t b = 0; b < ds.blocks.size(); ++b) {
    ds.blocks[b].name = std::move(mesh.blocks[b].name);
    ds.blocks[b].grid = std::move(mesh.blocks[b].grid);
  }
  return ds;
}

}  // namespace ugvr
