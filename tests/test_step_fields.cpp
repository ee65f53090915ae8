// Fields-only step reads (io/step_fields.h) and the exact scene's step switch through them: a later step of a .vtu
// series read without its mesh equals the full read; a step whose mesh moved (one point) or was reconnected is still
// caught (the walk mesh rebuilt); Exodus steps read from the file kept open; the read touches the field bytes only.
// OpenFOAM cases (copies of tests/data/openfoam with fields added): steps on the constant mesh read fields only, bit
// for bit the whole read (reconstructed, decomposed, polyhedral), a time directory's polyMesh/points read whole.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "hex_fixtures.h"
#include "openfoam_fixtures.h"
#include "step_fields_checks.h"
#include "test_data.h"
#include "ugvr/core/file.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/reader.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"
#include "ugvr/io/vtu_writer.h"
#include "ugvr/render/exact/exact_renderer.h"

namespace ugvr {
namespace {

using test::bytes_read_so_far;
using test::ScratchDir;

// test::step_cube_block as a dataset; `flipped` lists the first cell's corners in another order (the same points,
// other connectivity).
Dataset cube(int n, double offset, bool moved = false, bool flipped = false) {
  Block b = test::step_cube_block(n, offset, moved);
  if (flipped) {
    // The same hexahedron seen from its other end: a valid cell, other connectivity.
    uint32_t* v = std::get<UnstructuredMesh>(b.grid).connectivity.data();
    const uint32_t w[8] = {v[4], v[7], v[6], v[5], v[0], v[3], v[2], v[1]};
    std::copy(w, w + 8, v);
  }
  Dataset ds;
  ds.blocks.push_back(std::move(b));
  return ds;
}

std::shared_ptr<const TimeSeries> series_of(const std::string& path) {
  return std::make_shared<const TimeSeries>(list_time_steps(std::span<const std::string>(&path, 1)));
}

// Steps 0..count-1 of cube(n, 10 k), as step_k.vtu and a .pvd; `change(k)` may replace a step's dataset.
std::string write_series(const ScratchDir& dir, int n, int count, const VtuWriteOptions& options,
                         const std::function<Dataset(int)>& step = {}) {
  std::vector<std::pair<double, std::string>> steps;
  for (int k = 0; k < count; ++k) {
    const std::string name = "step_" + std::to_string(k) + ".vtu";
    write_vtu(step ? step(k) : cube(n, 10.0 * k), dir.file(name), options);
    steps.emplace_back(double(k), name);
  }
  write_pvd(dir.file("flow.pvd"), steps);
  return dir.file("flow.pvd");
}

// The values the engine holds for `field` on a scene built from step `k` alone.
std::vector<float> fresh_values(const TimeSeries& series, uint32_t k, const std::string& field) {
  ExactScene fresh(std::make_shared<const Dataset>(read_time_step(series, k)));
  fresh.bind(field);
  return fresh.engine.bound_values();
}

TEST(StepFields, LaterVtuStepsReadFieldsOnlyEqualTheFullRead) {
  for (const Codec codec : {Codec::None, Codec::Zlib}) {
    SCOPED_TRACE(codec == Codec::None ? "raw" : "zlib");
    ScratchDir dir;
    const auto series = series_of(write_series(dir, 4, 3, VtuWriteOptions{codec, 0}));
    StepFieldReader reader(series);
    EXPECT_FALSE(reader.static_by_format());
    const auto k0 = reader.geometry_keys(0), k1 = reader.geometry_keys(1);
    ASSERT_TRUE(k0.has_value());
    EXPECT_EQ(k0, k1) << "one mesh, other values: the same stored geometry";
    const StepFields fields = reader.read(1);
    const Dataset full = read_time_step(*series, 1);
    ASSERT_EQ(fields.blocks.size(), 1u);
    EXPECT_TRUE(fields.blocks[0] == full.blocks[0].fields);
    EXPECT_EQ(fields.format, full.format);
    EXPECT_EQ(fields.sources, full.sources);

    // Through the scene: vertex and cell fields swapped on the mesh held, none rebuilt.
    ExactScene scene(series, 0);
    for (const char* field : {"f", "c", "g:1"}) {
      SCOPED_TRACE(field);
      scene.bind(field);
      scene.set_step(scene.step == 1 ? 2 : 1);
      EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, scene.step, field));
      EXPECT_TRUE(scene.dataset->blocks[0].fields == read_time_step(*series, scene.step).blocks[0].fields);
    }
    scene.prefetch(0);
    scene.set_step(0);
    EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 0, "g:1"));
    EXPECT_EQ(scene.fields_only, 4u);
    EXPECT_EQ(scene.swaps, 4u);
    EXPECT_EQ(scene.rebuilds, 0u);
    EXPECT_EQ(std::get<UnstructuredMesh>(scene.dataset->blocks[0].grid).connectivity,
              std::get<UnstructuredMesh>(read_time_step(*series, 0).blocks[0].grid).connectivity);
  }
}

TEST(StepFields, AMovedPointOrOtherConnectivityIsCaughtAndRebuilds) {
  ScratchDir dir;
  // Step 2 moves one point; step 3 has step 0's points, counts and sizes but one cell's corners in another order.
  const auto series = series_of(write_series(dir, 3, 4, {}, [](int k) { return cube(3, 10.0 * k, k == 2, k == 3); }));
  StepFieldReader reader(series);
  const auto k0 = reader.geometry_keys(0);
  EXPECT_EQ(reader.geometry_keys(1), k0);
  EXPECT_NE(reader.geometry_keys(2), k0);
  EXPECT_NE(reader.geometry_keys(3), k0);

  ExactScene scene(series, 0);
  scene.bind("f");
  // A step read ahead for step 0's mesh, taken after the mesh changed, is read again for the mesh then held.
  scene.prefetch(1);
  scene.set_step(2);
  EXPECT_EQ(scene.rebuilds, 1u);
  EXPECT_EQ(scene.engine.bounds().lo.x, 0.0f);
  EXPECT_EQ(std::get<UnstructuredMesh>(scene.dataset->blocks[0].grid).points[0].x, 0.25f);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 2, "f"));
  scene.set_step(1);
  EXPECT_EQ(scene.rebuilds, 2u) << "step 1 has step 0's mesh, not step 2's";
  EXPECT_EQ(scene.fields_only, 0u);
  EXPECT_EQ(std::get<UnstructuredMesh>(scene.dataset->blocks[0].grid).points[0].x, 0.0f);
  scene.set_step(0);
  EXPECT_EQ(scene.fields_only, 1u);
  scene.set_step(3);
  EXPECT_EQ(scene.rebuilds, 3u) << "the same points, other connectivity";
  EXPECT_EQ(std::get<UnstructuredMesh>(scene.dataset->blocks[0].grid).connectivity,
            std::get<UnstructuredMesh>(read_time_step(*series, 3).blocks[0].grid).connectivity);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 3, "f"));
}

TEST(StepFields, ExodusStepsReadTheirVariablesFromTheFileKeptOpen) {
  UGVR_REQUIRE_DATA("exodus-misc/mug.e");
  const auto series = series_of(relative_data_path);
  StepFieldReader reader(series);
  ASSERT_TRUE(reader.static_by_format());
  for (uint32_t k : {20u, 3u, 20u}) {
    const StepFields fields = reader.read(k);
    const Dataset full = read_time_step(*series, k);
    ASSERT_EQ(fields.blocks.size(), 1u);
    EXPECT_TRUE(fields.blocks[0] == full.blocks[0].fields) << k;
    EXPECT_EQ(fields.format, full.format);
  }
  ExactScene scene(series, 0);
  scene.bind("convected");
  scene.set_step(20);
  EXPECT_EQ(scene.fields_only, 1u);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 20, "convected"));
  EXPECT_NE(scene.engine.bound_values(), fresh_values(*series, 0, "convected"));
  EXPECT_NE(test::error_of([&] { reader.read(21); }).find("does not exist: the series has 21 steps (0..20)"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { scene.set_step(21); }).find("the series has 21 steps"), std::string::npos);
  EXPECT_EQ(scene.step, 20u) << "a failed switch leaves the scene on its step";
}

TEST(StepFields, AFieldsOnlyReadReadsTheFieldBytesOnly) {
  if (bytes_read_so_far() == 0) GTEST_SKIP() << "no /proc/self/io";
  ScratchDir dir;
  const auto series = series_of(write_series(dir, 24, 2, {}));
  const uint64_t file = InputFile(series->steps[1].files[0]).size();
  // The fields: f and c (4 bytes a point or cell), g (12 bytes a point); the rest is points and cells (the
  // connectivity alone 32 bytes a cell).
  const uint64_t points = 25 * 25 * 25, cells = 24 * 24 * 24, field_bytes = 16 * points + 4 * cells;
  StepFieldReader reader(series);
  uint64_t before = bytes_read_so_far();
  const StepFields fields = reader.read(1);
  const uint64_t fields_only = bytes_read_so_far() - before;
  before = bytes_read_so_far();
  const Dataset full = read_time_step(*series, 1);
  const uint64_t whole = bytes_read_so_far() - before;
  EXPECT_GE(whole, file) << "the counter sees the full read";
  EXPECT_GE(fields_only, field_bytes);
  // Beside them: the types array (1 byte a cell: which cells' values the mesh keeps), the first 64 KiB the markup's
  // scan reads, the arrays' headers.
  EXPECT_LT(fields_only, field_bytes + cells + 68 * 1024) << "the field arrays and the markup, nothing of the mesh";
  EXPECT_LT(fields_only * 2, file);
  EXPECT_TRUE(fields.blocks[0] == full.blocks[0].fields);
}

// A file that shrinks after it was opened, while its bytes are hashed for a geometry key, is an error naming the file
// and the offset where the bytes ran short. (Hashed from a mapping, as before, touching the pages past the new end
// raised SIGBUS and ended the process: this test crashed.)
TEST(StepFields, AFileTruncatedWhileItsKeyIsHashedIsAnErrorNotSigbus) {
  ScratchDir dir;
  const std::string path = dir.file("shrinks.bin");
  constexpr size_t kSize = size_t(3) << 20;
  std::ofstream(path, std::ios::binary) << std::string(kSize, 'x');
  const InputFile file(path);
  const uint64_t whole = hash_file_range(file, 0, kSize);
  std::filesystem::resize_file(path, kSize / 2);
  const std::string e = test::error_of([&] { hash_file_range(file, 0, kSize); });
  EXPECT_NE(e.find(path + ": was truncated while reading: expected 1048576 bytes at offset "), std::string::npos) << e;
  // A range past the end of the file as opened (a header promising more bytes than the file holds).
  const InputFile shorter(path);
  const std::string past = test::error_of([&] { hash_file_range(shorter, 0, kSize); });
  EXPECT_NE(past.find("unexpected end of file"), std::string::npos) << past;
  // The same bytes again, the same hash (parts read by any thread, combined in order).
  std::ofstream(path, std::ios::binary) << std::string(kSize, 'x');
  EXPECT_EQ(hash_file_range(InputFile(path), 0, kSize), whole);
}

// A step file truncated after its key was cached: the size changed, so the key is computed again, which fails naming
// the file; the switch fails as a whole read of that file would, the scene stays on its step, and the file written
// again switches fields-only.
TEST(StepFields, AStepFileTruncatedAfterItsKeyWasCachedFailsCleanly) {
  ScratchDir dir;
  const auto series = series_of(write_series(dir, 6, 3, {}));
  const std::string step2 = series->steps[2].files[0];
  const uintmax_t size = std::filesystem::file_size(step2);
  ExactScene scene(series, 0);
  scene.bind("f");
  scene.set_step(2);  // its key cached in the scene's reader
  scene.set_step(1);
  StepFieldReader reader(series);
  ASSERT_TRUE(reader.geometry_keys(2).has_value());
  std::filesystem::resize_file(step2, size / 2);
  EXPECT_NE(test::error_of([&] { reader.geometry_keys(2); }).find("step_2.vtu"), std::string::npos);
  const std::string e = test::error_of([&] { scene.set_step(2); });
  EXPECT_NE(e.find("step_2.vtu"), std::string::npos) << e;
  EXPECT_NE(test::error_of([&] { read_time_step(*series, 2); }), "(no error)") << "the whole read fails too";
  EXPECT_EQ(scene.step, 1u) << "a failed switch leaves the scene on its step";
  write_vtu(cube(6, 20.0), step2, {});
  scene.set_step(2);
  EXPECT_EQ(scene.fields_only, 3u);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 2, "f"));
}

// ---- OpenFOAM

namespace fs = std::filesystem;

using test::bytes_under;
using test::copy_openfoam_case;
using test::expect_same_bits;
using test::expect_whole_read;
using test::write_point_field;

// The cavity case (4 time directories, a cellZones file, a surface field phi the reader skips with a note) with a
// point field added to the later steps: every step has the constant mesh, and each step's fields read without it
// equal the whole read bit for bit (cell and vertex fields, the cellZone field, the notes). Through the scene every
// switch swaps fields on the walk mesh built once. The fields-only read reads the time directory's files, not the
// mesh's.
TEST(StepFields, OpenFoamStepsOnTheConstantMeshReadFieldsOnly) {
  ScratchDir dir;
  const std::string root = copy_openfoam_case(dir, "cavity");
  for (int k = 1; k <= 3; ++k) write_point_field(fs::path(root) / ("0." + std::to_string(k)), 882, 0.5 * k);
  const auto series = series_of(root);
  ASSERT_EQ(series->kind, SeriesKind::OpenFoam);
  ASSERT_EQ(series->size(), 4u);
  StepFieldReader reader(series);
  const Dataset shown = reader.read_whole(0);
  const auto k0 = reader.geometry_keys(0);
  ASSERT_TRUE(k0.has_value());
  for (size_t k = 1; k < 4; ++k) {
    EXPECT_EQ(reader.geometry_keys(k), k0);
    EXPECT_TRUE(reader.has_mesh_of(k, 0));
  }
  for (size_t k : {3u, 1u, 2u, 0u}) expect_whole_read(*series, reader.read(k), k);
  EXPECT_NE(reader.read(2).blocks[0].find("pw", Association::Vertex), nullptr);
  EXPECT_NE(reader.read(2).blocks[0].find("cellZone", Association::Cell), nullptr);

  if (bytes_read_so_far() != 0) {
    const fs::path time = fs::path(root) / "0.3";
    uint64_t before = bytes_read_so_far();
    reader.read(3);
    const uint64_t fields_only = bytes_read_so_far() - before;
    before = bytes_read_so_far();
    read_time_step(*series, 3);
    const uint64_t whole = bytes_read_so_far() - before;
    // Each field file is read once, and its first 4 KiB once more (has_foam_header); the mesh's files not at all.
    // (1 KiB more: reading /proc/self/io counts too.)
    EXPECT_LE(fields_only, bytes_under(time) + 4 * 4096 + 1024);
    EXPECT_GE(whole, fields_only + bytes_under(fs::path(root) / "constant" / "polyMesh"));
  }

  ExactScene scene(series, 0);
  // The scene's first switch reads fields only: the read that made the scene kept the mesh's layout.
  const uint64_t before_switch = bytes_read_so_far();
  scene.set_step(2);
  if (before_switch != 0) {
    EXPECT_LE(bytes_read_so_far() - before_switch, bytes_under(fs::path(root) / "0.2") + 4 * 4096 + 1024);
  }
  for (const char* field : {"p", "pw", "U:1"}) {
    SCOPED_TRACE(field);
    scene.bind(field);
    scene.set_step(scene.step == 3 ? 2 : 3);
    EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, scene.step, field));
  }
  scene.prefetch(1);
  scene.set_step(1);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 1, "U:1"));
  EXPECT_EQ(scene.fields_only, 5u);
  EXPECT_EQ(scene.rebuilds, 0u);
}

// A decomposed case (two processor directories, concatenated) and the polyhedral dual mesh (polyhedra split around
// their centres: cell data repeated on the pieces, point data averaged at the added centres) read fields-only equal
// the whole read bit for bit; a reader that kept no layout reads its first step whole, then fields only.
TEST(StepFields, OpenFoamDecomposedAndPolyhedralStepsReadFieldsOnly) {
  ScratchDir dir;
  {
    const auto series = series_of(copy_openfoam_case(dir, "cavity_decomposed"));
    StepFieldReader reader(series);
    reader.read_whole(3);
    for (size_t k : {0u, 2u}) expect_whole_read(*series, reader.read(k), k);
  }
  const std::string dual = copy_openfoam_case(dir, "dual");
  write_point_field(fs::path(dual) / "0.02", 692, 0.25);
  write_point_field(fs::path(dual) / "0", 692, 1.0);
  const auto series = series_of(dual);
  ASSERT_EQ(series->size(), 2u);
  StepFieldReader reader(series);
  expect_whole_read(*series, reader.read(1), 1);  // no layout kept: read whole, its layout kept
  expect_whole_read(*series, reader.read(0), 0);
  const StepFields f = reader.read(1);
  const Field* pw = f.blocks[0].find("pw", Association::Vertex);
  ASSERT_NE(pw, nullptr);
  EXPECT_GT(pw->tuples(), 692u) << "centre points added by the decomposition have values";

  ExactScene scene(series, 0);
  scene.bind("pw");
  scene.set_step(1);
  EXPECT_EQ(scene.fields_only, 1u);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 1, "pw"));
}

// A time directory with its own polyMesh/points moves the mesh: that step has no key, is read whole, and the walk
// mesh is rebuilt; the steps after it on the constant mesh switch back (rebuilt) and then read fields only again.
TEST(StepFields, OpenFoamATimeDirectoryWithPointsMovesTheMesh) {
  ScratchDir dir;
  const std::string root = copy_openfoam_case(dir, "cavity");
  const fs::path moved = fs::path(root) / "0.2" / "polyMesh";
  fs::create_directories(moved);
  {
    std::ifstream in(fs::path(root) / "constant" / "polyMesh" / "points");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t at = text.find("(0 0 0)");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, 7, "(0 0 -0.001)");
    std::ofstream(moved / "points") << text;
  }
  const auto series = series_of(root);
  StepFieldReader reader(series);
  EXPECT_FALSE(reader.geometry_keys(2).has_value());
  EXPECT_FALSE(reader.has_mesh_of(2, 0));
  EXPECT_EQ(reader.geometry_keys(3), reader.geometry_keys(0));
  EXPECT_NE(test::error_of([&] { reader.read(2); }).find("moves the mesh"), std::string::npos);

  ExactScene scene(series, 0);
  scene.bind("p");
  scene.set_step(1);
  EXPECT_EQ(scene.fields_only, 1u);
  EXPECT_EQ(scene.engine.bounds().lo.z, 0.0f);
  scene.set_step(2);
  EXPECT_EQ(scene.rebuilds, 1u);
  EXPECT_EQ(scene.engine.bounds().lo.z, -0.001f);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 2, "p"));
  scene.set_step(3);
  EXPECT_EQ(scene.rebuilds, 2u) << "back on the constant mesh";
  EXPECT_EQ(scene.engine.bounds().lo.z, 0.0f);
  scene.set_step(1);
  EXPECT_EQ(scene.fields_only, 2u);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 1, "p"));
}

// A truncated field file at a step: the fields-only read fails naming the file, as the whole read does; the scene
// stays on its step and nothing is kept of the failed read (the file written again switches). A field file missing
// from a step: the field is absent from that step, as in the whole read.
TEST(StepFields, OpenFoamADamagedOrMissingFieldFileAtAStep) {
  ScratchDir dir;
  const std::string root = copy_openfoam_case(dir, "cavity");
  const fs::path p = fs::path(root) / "0.2" / "p";
  const uintmax_t size = fs::file_size(p);
  const std::string saved = [&] {
    std::ifstream in(p);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }();
  fs::remove(fs::path(root) / "0.3" / "U");
  const auto series = series_of(root);
  ExactScene scene(series, 0);
  scene.bind("p");
  fs::resize_file(p, size / 2);
  const std::string whole = test::error_of([&] { read_time_step(*series, 2); });
  const std::string e = test::error_of([&] { scene.set_step(2); });
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_EQ(e, whole) << "the same error as the whole read";
  EXPECT_EQ(scene.step, 0u);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 0, "p"));
  std::ofstream(p) << saved;
  scene.set_step(2);
  EXPECT_EQ(scene.engine.bound_values(), fresh_values(*series, 2, "p"));
  expect_whole_read(*series, scene.step_reader().read(3), 3);
  EXPECT_EQ(scene.step_reader().read(3).blocks[0].find("U"), nullptr);
  EXPECT_EQ(scene.fields_only, 1u);
}

}  // namespace
}  // namespace ugvr
