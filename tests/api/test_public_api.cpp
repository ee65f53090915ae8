// The public API (include/ugvr/ugvr.h) as a program using the library sees it: this file is compiled with include/ on
// its include path and nothing from src/, so a public header that reaches into the library's private headers fails
// the build here. It reads a small mesh, renders it with the exact engine, builds its brick store and renders that
// with the level-of-detail engine, one frame and interactively.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "ugvr/ugvr.h"

namespace {

namespace fs = std::filesystem;

// Two hexahedra side by side, split into 12 tetrahedra (legacy VTK, ASCII) with a point field that varies along x.
std::string write_mesh(const fs::path& dir) {
  const fs::path path = dir / "bar.vtk";
  std::ofstream out(path);
  out << "# vtk DataFile Version 3.0\nbar\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 12 float\n";
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) out << i << " " << j << " " << k << "\n";
  const auto id = [](int i, int j, int k) { return i * 4 + j * 2 + k; };
  out << "CELLS 2 18\n";
  for (int i = 0; i < 2; ++i)
    out << "8 " << id(i, 0, 0) << " " << id(i + 1, 0, 0) << " " << id(i + 1, 1, 0) << " " << id(i, 1, 0) << " "
        << id(i, 0, 1) << " " << id(i + 1, 0, 1) << " " << id(i + 1, 1, 1) << " " << id(i, 1, 1) << "\n";
  out << "CELL_TYPES 2\n12\n12\nPOINT_DATA 12\nSCALARS heat float 1\nLOOKUP_TABLE default\n";
  for (int i = 0; i < 3; ++i)
    for (int n = 0; n < 4; ++n) out << float(i * i) << "\n";
  return path.string();
}

class PublicApi : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ugvr-api-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    mesh_ = write_mesh(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // Pixels that differ from the background: the data was drawn.
  static int drawn(const ugvr::Image& image, const ugvr::FrameRequest& request) {
    int n = 0;
    for (size_t i = 0; i < image.rgba.size(); i += 4)
      if (std::abs(image.rgba[i] - float(request.settings.background[0])) > 0.02f) ++n;
    return n;
  }
  fs::path dir_;
  std::string mesh_;
};

TEST_F(PublicApi, ReadRenderBuildAndRenderAgain) {
  EXPECT_STRNE(ugvr::version(), "");
  auto dataset = std::make_shared<const ugvr::Dataset>(ugvr::read_dataset(std::vector<std::string>{mesh_}));
  auto exact = ugvr::make_renderer(dataset, {});
  EXPECT_EQ(exact->engine(), "exact");
  EXPECT_EQ(exact->field_name(), "heat");
  EXPECT_DOUBLE_EQ(exact->field_range().max, 4.0);
  ugvr::FrameRequest request = ugvr::default_request(*exact, 40, 30, "iso");
  const ugvr::Frame frame = exact->render(request);
  ASSERT_EQ(frame.image.width, 40);
  EXPECT_TRUE(frame.stats.converged);
  EXPECT_GT(drawn(frame.image, request), 50);

  const std::string store = (dir_ / "bar.ugvr").string();
  ugvr::StoreOptions so;
  so.brick = 8;
  so.max_depth = 2;
  const ugvr::StoreSummary built = ugvr::build_store({mesh_}, store, so);
  EXPECT_EQ(built.fields, std::vector<std::string>{"heat"});
  EXPECT_GT(built.bricks, 0u);
  EXPECT_TRUE(fs::exists(store));

  auto lod = ugvr::open_renderer({store}, {});
  EXPECT_EQ(lod->engine(), "lod");
  EXPECT_FALSE(lod->device().empty());
  const ugvr::Frame lod_frame = lod->render(request);
  EXPECT_GT(drawn(lod_frame.image, request), 50);

  ugvr::RendererConfig interactive;
  interactive.interactive = true;
  auto session = ugvr::open_renderer({store}, interactive);
  request.target_fps = 30;
  request.full_quality = true;
  const ugvr::Frame converged = session->render(request);
  EXPECT_TRUE(converged.stats.converged);
  EXPECT_GT(converged.stats.cut_nodes, 0u);
}

// A newcomer's first request: an oblique view framed on the data (+z up) and an opacity unit distance of a tenth of
// the diagonal; without a field named, the first field that varies is drawn (the bar's "still" is constant).
TEST_F(PublicApi, DefaultRequestAndFieldShowTheData) {
  {
    std::ifstream in(mesh_);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string data = "POINT_DATA 12\n";
    std::string still = "SCALARS still float 1\nLOOKUP_TABLE default\n";
    for (int i = 0; i < 12; ++i) still += "7\n";
    text.insert(text.find(data) + data.size(), still);
    std::ofstream(dir_ / "still.vtk") << text;
  }
  const std::string mesh = (dir_ / "still.vtk").string();
  auto dataset = std::make_shared<const ugvr::Dataset>(ugvr::read_dataset(std::vector<std::string>{mesh}));
  auto exact = ugvr::make_renderer(dataset, {});
  EXPECT_EQ(exact->field_name(), "heat");
  auto opened = ugvr::open_renderer({mesh}, {});
  EXPECT_EQ(opened->field_name(), "heat");
  ugvr::RendererConfig named;
  named.field = "still";
  EXPECT_EQ(ugvr::open_renderer({mesh}, named)->field_name(), "still");

  const ugvr::FrameRequest request = ugvr::default_request(*exact, 40, 30);
  const ugvr::Vec3d d = request.camera.direction();
  EXPECT_GT(d.x, 0.3);
  EXPECT_GT(d.y, 0.3);
  EXPECT_LT(d.z, -0.3);
  EXPECT_GT(request.camera.view_up.z, 0.8);
  const double diagonal = std::sqrt(2 * 2 + 1 + 1);
  // auto's unit distance: a tenth of the diagonal, and a tenth of that when it hides a bump of the histogram (an
  // interior opacity point at 0: what is left visible is thin; render/default_transfer_function.h). Volume-weighted,
  // this mesh's histogram has such a bump.
  const auto& op = request.tf.opacity_points;
  bool hides_a_bump = false;
  for (size_t i = 1; i + 1 < op.size(); ++i) hides_a_bump = hides_a_bump || op[i].opacity == 0;
  EXPECT_TRUE(hides_a_bump);
  EXPECT_NEAR(request.tf.opacity_unit_distance, diagonal / 10 * 0.1, 1e-12);
  EXPECT_EQ(request.tf.range_max(), 4.0);
  EXPECT_EQ(request.settings.field, "heat");
  EXPECT_GT(drawn(exact->render(request).image, request), 50);
}

// A build reports its own progress to its caller, and stops when the callback says so (nothing written).
TEST_F(PublicApi, BuildProgressIsPerCallAndCancels) {
  ugvr::StoreOptions so;
  so.brick = 8;
  so.max_depth = 3;
  std::vector<std::string> stages;
  double last = -1;
  so.progress = [&](std::string_view stage, double fraction) {
    if (stages.empty() || stages.back() != stage) stages.emplace_back(stage);
    last = fraction;
    return true;
  };
  const std::string store = (dir_ / "p.ugvr").string();
  ugvr::build_store({mesh_}, store, so);
  ASSERT_FALSE(stages.empty());
  EXPECT_EQ(stages.back(), "bricks");
  EXPECT_DOUBLE_EQ(last, 1.0);

  so.progress = [](std::string_view, double) { return false; };
  const std::string cancelled = (dir_ / "c.ugvr").string();
  EXPECT_THROW(ugvr::build_store({mesh_}, cancelled, so), ugvr::Error);
  EXPECT_FALSE(fs::exists(cancelled));
}

TEST_F(PublicApi, ErrorsNameTheOptionAtFault) {
  ugvr::RendererConfig config;
  config.field = "nope";
  try {
    ugvr::open_renderer({mesh_}, config);
    FAIL() << "an unknown field was accepted";
  } catch (const ugvr::Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("field: ", 0), 0u) << e.what();
  }
  config = {};
  config.cut = "nodes:3";
  EXPECT_THROW(ugvr::open_renderer({mesh_}, config), ugvr::Error);
  ugvr::FrameRequest request;
  request.time_step = 2;
  auto exact = ugvr::open_renderer({mesh_}, {});
  EXPECT_THROW(exact->render(request), ugvr::Error);
}

}  // namespace
