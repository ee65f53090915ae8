// OpenFOAM's FoamFile format, the pieces the case reader (read_openfoam in reader.h) and the fuzz target share.
//
// A FoamFile is a C++-comment-decorated text file: a "FoamFile { format ascii|binary; class ...; arch
// "LSB;label=32;scalar=64"; }" header, then either one list (polyMesh points, faces, owner, neighbour) or dictionary
// entries (fields: "dimensions [...]; internalField uniform V | nonuniform List<T> N(...); boundaryField {...}";
// boundary and cellZones: "N ( name { ... } ... )"). Lists are "N ( a b c )" (vectors "(x y z)", faces "k(i j ..)"),
// "N { v }" (N copies of v), and in binary files "N(" followed by N raw little- or big-endian values and ")". A file
// may be gzip-compressed (OpenFOAM writes NAME.gz).
//
// Streaming: the parser never holds a file whole. It reads through a window of at most `window` bytes (1 MiB by
// default) refilled from the file, from zlib's inflate stream for a .gz file (no inflated copy is made), or from the
// bytes given. A refill keeps the token being read; a token (word, number, quoted string) that does not fit the window
// is gathered in a side buffer of at most kMaxToken bytes. Comments may span refills; binary lists are decoded value
// by value straight into the output vectors. So the reader's memory is the window plus what it returns, whatever the
// file's size; peak_window_bytes() reports the window's (and side buffer's) high-water mark. A gzip stream is inflated
// to its end once the values are read (its CRC and length checked), at most deflate's 1032:1 of the compressed size.
//
// Counts: for a plain file (and bytes given) every count is checked against the bytes left before anything is
// allocated for it. A gzip file's inflated size is unknown until its end, so its counts are not trusted for
// allocation: vectors reserve at most a few MiB and grow as values arrive, and a count larger than the data fails at
// the data's end ("... needs N bytes of binary data, only R remain", "found the end of the file"). Errors name the
// file, the byte offset (in the inflated text for a .gz file) and the line (newlines are counted as the window moves
// on, so lines stay exact however far back the offset is).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
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
  // The window's default size, and the longest token (word, number, quoted string) accepted.
  static constexpr size_t kDefaultWindow = size_t(1) << 20;
  static constexpr size_t kMaxToken = size_t(64) << 10;
  // The smallest window (tests use tiny windows so that every token, comment and binary value crosses a refill).
  static constexpr size_t kMinWindow = 16;

  // Opens the file (gzip data is recognised by its magic bytes and inflated as it is read) and parses the header.
  explicit FoamFile(const std::string& path, size_t window = kDefaultWindow);
  // The same over bytes already in memory; `name` is used in messages.
  FoamFile(std::string name, std::string bytes, size_t window = kDefaultWindow);
  ~FoamFile();
  FoamFile(const FoamFile&) = delete;
  FoamFile& operator=(const FoamFile&) = delete;

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

  // The most bytes the window and the side buffer for long tokens held at once.
  uint64_t peak_window_bytes() const { return peak_; }

  // Where the window's bytes come from: a file, memory, or an inflate stream over either (defined in the .cpp).
  struct Source;

 private:
  // A place in the text: its byte offset and line, taken when the place was read (the window may have moved on).
  struct Spot {
    uint64_t offset = 0;
    uint64_t line = 1;
  };

  [[noreturn]] void fail(Spot at, const std::string& message) const;
  void open(std::unique_ptr<Source> raw, uint64_t raw_size, bool gzip, size_t window);
  // Window: bytes [base_, base_ + len_) of the text are buf_[0, len_).
  uint64_t end() const { return base_ + len_; }
  const char* ptr(uint64_t offset) const { return buf_.data() + (offset - base_); }
  char byte(uint64_t offset) const { return buf_[size_t(offset - base_)]; }
  // Makes the byte at `offset` readable, keeping [keep, offset] in the window; false at the end of the text.
  bool reach(uint64_t offset, uint64_t keep) {
    while (offset >= end())
      if (!refill(keep)) return false;
    return true;
  }
  bool more() { return reach(pos_, pos_); }  // a byte at pos_
  bool refill(uint64_t keep);
  // Line bookkeeping: newlines before line_at_ are counted in line_; counting only moves forward with the window.
  uint64_t line_of(uint64_t offset) { return offset == line_at_ ? line_ : count_lines(offset); }
  uint64_t count_lines(uint64_t offset);
  Spot here() { return {pos_, line_of(pos_)}; }
  void note_peak();
  // Checks a count against the bytes left where the size is known (plain files, bytes); gzip: no check.
  void check_fits(std::string_view what, uint64_t n, uint64_t min_bytes_each, uint64_t slack);
  // How many values to reserve for `n` announced: all of them where the count was checked, else a few MiB's worth.
  size_t reserve_for(uint64_t n, size_t each) const;
  // Binary values of `each` bytes, `n` of them, passed to `take(pointer, index)` as they arrive. `block` is where
  // the block began (errors name it).
  template <class Take>
  void binary_values(uint64_t n, size_t each, Spot block, std::string_view what, Take&& take);
  void skip_line();
  void verify_rest();
  // Whether the text at pos_ is the word `w` (followed by a space, delimiter, comment or the end); consumed if so.
  bool accept_word(std::string_view w);

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
  void skip_value();
  // Reads "N (...)" / "N {v}" / binary "N(...)" of `components`-tuples of scalars (labels when `labels`).
  std::vector<double> scalar_list(int components, std::string_view what, std::optional<uint64_t> expected);
  std::vector<int64_t> label_list(std::string_view what, int64_t max_label, bool allow_minus_one);
  double binary_scalar(const char* p) const;
  int64_t binary_label(const char* p) const;

  std::string name_;
  std::unique_ptr<Source> source_;
  std::optional<uint64_t> size_;  // the text's size where known before reading it (not for gzip)
  std::string buf_;               // the window, allocated once
  uint64_t base_ = 0;
  size_t len_ = 0;
  bool eof_ = false;
  uint64_t pos_ = 0;  // absolute offset of the next unread byte
  uint64_t line_at_ = 0, line_ = 1;
  std::string token_;  // a token that crossed a refill
  uint64_t peak_ = 0;
  FoamHeader header_;
};

// Whether `path` names an OpenFOAM case: a directory holding constant/polyMesh or processor*/constant/polyMesh, a
// *.foam / *.OpenFOAM file (ParaView's convention: an empty file in the case directory) or a controlDict.
bool is_openfoam_path(const std::string& path);

}  // namespace ugvr::openfoam

namespace ugvr {

struct Dataset;
class FieldSet;

// Fields-only step reads (io/step_fields.h). A step whose time directory has no polyMesh/points nor polyMesh/faces
// (in no processor directory of a decomposed case) has the case's constant mesh, that of every other such step. What a
// step's fields need of that mesh (each piece's cell and point counts before decomposition, the polyhedra
// decomposition's cell order and centre points, the cellZone field, the mesh's notes) is an OpenFoamLayout, kept from
// a whole read of the mesh; a later step's fields are then read from its time directory alone, through the same
// decoding as the whole read, nothing of constant/polyMesh read.
struct OpenFoamLayout;

// The stored identity of the mesh step `time_step` reads: a hash of its pieces' directories and their constant/polyMesh
// files' names, sizes and modification times; nullopt where the step's time directory moves the mesh (read it whole).
// Lists directories and stats files; reads none. Throws ugvr::Error as read_openfoam does for a bad case or step.
std::optional<uint64_t> openfoam_mesh_key(const std::string& path, int64_t time_step);
// read_openfoam (io/reader.h), and where `kept` is given the layout of the mesh read, for read_openfoam_fields.
Dataset read_openfoam(const std::string& path, int64_t time_step, std::shared_ptr<const OpenFoamLayout>* kept);
// The mesh key the layout was read with (openfoam_mesh_key of its step, taken before the mesh was read).
const std::optional<uint64_t>& openfoam_layout_mesh_key(const OpenFoamLayout& layout);
// Step `time_step`'s fields on the layout's mesh: bit for bit the fields read_openfoam gives for that step, in its
// order; `format`, `sources` and `warnings` as the whole read sets the dataset's. The caller has checked that the
// step's mesh key is the layout's. Throws ugvr::Error naming the file for a missing or damaged field file.
FieldSet read_openfoam_fields(const OpenFoamLayout& layout, const std::string& path, int64_t time_step,
                              std::string& format, std::vector<std::string>& sources,
                              std::vector<std::string>& warnings);

}  // namespace ugvr
