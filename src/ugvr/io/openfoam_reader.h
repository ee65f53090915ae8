// OpenFOAM's FoamFile format, the pieces the case reader (read_openfoam in reader.h) and the fuzz target share.
//
// A FoamFile is a C++-comment-decorated text file: a "FoamFile { format ascii|binary; class ...; arch
// "LSB;label=32;scalar=64"; }" header, then either one list (polyMesh points, faces, owner, neighbour) or dictionary
// entries (fields: "dimensions [...]; internalField uniform V | nonuniform List<T> N(...); boundaryField {...}";
// boundary and cellZones: "N ( name { ... } ... )"). Lists are "N ( a b c )" (vectors "(x y z)", faces "k(i j ..)"),
// "N { v }" (N copies of v), and in binary files "N(" followed by N raw little- or big-endian values and ")". A file
// may be gzip-compressed (OpenFOAM writes NAME.gz); it is inflated whole into memory first: the files of one case are
// read one at a time, so the peak is one file's text beside the mesh being built.
//
// Every count is checked against the bytes left before anything is allocated for it, and errors name the file, the
// byte offset (in the inflated text for a .gz file) and the line.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/vec.h"

namespace ugvr::openfoam {

struct FoamHeader {
  bool binary = false;
  std::string class_name;  // "vectorField", "faceCompactList", "volScalarField", ...
  std::string object;
  int label_bytes = 4;   // arch "label=32|64"
  int scalar_bytes = 8;  // arch "scalar=32|64"
  bool big_endian = false;
};

// Polygons as CSR: face f has vertices[offsets[f] .. offsets[f+1]).
struct FaceList {
  std::vector<uint64_t> offsets{0};
  std::vector<uint32_t> vertices;
  uint64_t size() const { return offsets.size() - 1; }
};

struct Patch {  // constant/polyMesh/boundary: faces [start_face, start_face + n_faces) are on the patch
  std::string name, type;
  uint64_t n_faces = 0, start_face = 0;
};

struct CellZone {
  std::string name;
  std::vector<uint64_t> cells;
};

// A field's internal values: `components` doubles per tuple (1 scalar, 3 vector, 6 symmTensor, 9 tensor).
struct FieldValues {
  int components = 1;
  std::vector<double> values;
  bool uniform = false;
};

class FoamFile {
 public:
  // Reads the file (inflating gzip data, recognised by its magic bytes) and parses the header.
  explicit FoamFile(const std::string& path);
  // The same over bytes already in memory; `name` is used in messages.
  FoamFile(std::string name, std::string bytes);

  const FoamHeader& header() const { return header_; }
  const std::string& name() const { return name_; }

  // The body as one list. `point_count` bounds face vertex indices; `max_label` bounds labels (owner, neighbour: a
  // label of -1 is kept as -1 where allow_minus_one).
  std::vector<Vec3f> points();
  FaceList faces(uint64_t point_count);
  std::vector<int64_t> labels(int64_t max_label, bool allow_minus_one);
  // The body as "N ( name { ... } )" dictionaries.
  std::vector<Patch> patches();
  std::vector<CellZone> cell_zones(uint64_t cell_count);
  // The internalField entry of a geometric field of `tuples` values; nullopt when the file has none.
  std::optional<FieldValues> internal_field(uint64_t tuples);

 private:
  [[noreturn]] void fail(uint64_t at, const std::string& message) const;
  void parse_header();
  void skip_space();
  bool at_end();
  char peek();
  bool accept(char c);
  void expect(char c, std::string_view what);
  std::string_view word(std::string_view what);
  uint64_t count(std::string_view what);
  int64_t integer(std::string_view what);
  double number(std::string_view what);
  std::string_view raw(uint64_t bytes, std::string_view what);
  void skip_value();
  // Reads "N (...)" / "N {v}" / binary "N(...)" of `components`-tuples of scalars (labels when `labels`).
  std::vector<double> scalar_list(int components, std::string_view what, std::optional<uint64_t> expected);
  std::vector<int64_t> label_list(std::string_view what, int64_t max_label, bool allow_minus_one);
  double binary_scalar(const char* p) const;
  int64_t binary_label(const char* p) const;

  std::string name_;
  std::string text_;
  size_t pos_ = 0;
  FoamHeader header_;
};

// Whether `path` names an OpenFOAM case: a directory holding constant/polyMesh or processor*/constant/polyMesh, a
// *.foam / *.OpenFOAM file (ParaView's convention: an empty file in the case directory) or a controlDict.
bool is_openfoam_path(const std::string& path);

}  // namespace ugvr::openfoam
