// Smooth brush edges (the [hybrid] issue, item 4; docs/hybrid.md, "Focus+context"): a focus range may carry an edge
// (`FIELD:MIN:MAX~EDGE`) over which a value's interest falls from 1 to 0. A node's interest is the window at the
// distance between the range and the node's value range; where every range is on the rendered field the LOD shader
// mixes each sample between its full colour and its context colour by its own value's interest, so that the border
// runs through a node instead of along node boxes.
//
// The data: a box [0, 1]³ of tetrahedra with "x" = the x coordinate and "y" = the y coordinate (both linear, which
// trilinear bricks hold exactly), built to a store of one node: every border the tests see lies inside that node.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "gl_test_support.h"
#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/gpu/gl_context.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/grid/structured_cells.h"
#include "ugvr/grid/structured_grid.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/hybrid_select.h"
#include "ugvr/render/lod/lod_engine.h"
#include "ugvr/store/brick_store.h"
#include "ugvr/view/view_protocol.h"

namespace ugvr {
namespace {

Dataset ramp_dataset() {
  StructuredGrid g;
  const uint32_t n = 9;
  g.dims = GridDims{{n, n, 3}};
  std::vector<float> xs, ys;
  for (uint32_t k = 0; k < 3; ++k)
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        const Vec3f p{float(i) / float(n - 1), float(j) / float(n - 1), float(k) / 2.0f};
        g.points.push_back(p);
        xs.push_back(p.x);
        ys.push_back(p.y);
      }
  Block b;
  b.name = "ramp";
  b.grid = std::move(g);
  b.fields.add(Field("x", Association::Vertex, DataArray::from(std::move(xs), 1)));
  b.fields.add(Field("y", Association::Vertex, DataArray::from(std::move(ys), 1)));
  Dataset ds;
  ds.sources = {"ramp"};
  ds.blocks.push_back(to_unstructured_block(b, StructuredCellShape::SixTetrahedra));
  return ds;
}

struct Shared {
  std::filesystem::path dir;
  std::string store;
  std::unique_ptr<GlContext> gl;
  std::string gl_error;
};

Shared& shared() {
  static Shared s = [] {
    Shared r;
    r.dir = std::filesystem::temp_directory_path() / ("ugvr-test-focus-edge-" + std::to_string(::getpid()));
    std::filesystem::create_directories(r.dir);
    r.store = (r.dir / "ramp.ugvr").string();
    const std::vector<std::string> fields = {"x", "y"};
    OctreeBuildOptions o;
    o.resolution = 16;
    o.max_depth = 0;  // the root alone: one node holds every border
    build_octree(prepare_octree_input(ramp_dataset(), fields), o, r.store);
    r.gl = test::open_gl_context(r.gl_error);
    return r;
  }();
  return s;
}

#define REQUIRE_GL() UGVR_REQUIRE_GL_CONTEXT(shared().gl, shared().gl_error)

TEST(FocusEdge, ParsesAndRoundTrips) {
  const std::vector<FocusRange> f = parse_focus("x:0:0.5~0.25+a~b:1:2,velocity:magnitude:-1:1e3~1e-3");
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(f[0], (FocusRange{"x", 0, 0.5, 0, 0.25}));
  EXPECT_EQ(f[1], (FocusRange{"a~b", 1, 2, 0, 0})) << "a '~' before the last ':' is the field name's";
  EXPECT_EQ(f[2], (FocusRange{"velocity:magnitude", -1, 1000, 1, 1e-3}));
  EXPECT_EQ(parse_focus(focus_text(f)), f);
  EXPECT_EQ(focus_text(parse_focus("p:0:1~0")), focus_text(parse_focus("p:0:1"))) << "a zero edge is no edge";
  EXPECT_EQ(focus_text(parse_focus("p:0:1")), "p:0:1") << "texts without edges as before";
  for (const char* bad : {"p:0:1~", "p:0:1~-1", "p:0:1~x", "p:0:1~inf", "p:0:1~1~2", "p~1", "p:0:1~1+q:0:1~"}) {
    const std::string message = test::error_of([&] { parse_focus(bad); });
    EXPECT_NE(message.find(std::string("--focus ") + bad), std::string::npos) << bad << ": " << message;
  }
  EXPECT_NE(test::error_of([] { parse_focus("p:0:1~-1"); }).find("negative"), std::string::npos);
}

// The viewer's interest message carries the same texts; a bad edge is an error naming the key.
TEST(FocusEdge, ViewerInterestMessageCarriesTheEdge) {
  const view::ClientMessage m = view::parse_client_message(R"({"type":"interest","focus":"pressure:0:1~0.5"})");
  const auto* interest = std::get_if<view::InterestMessage>(&m);
  ASSERT_TRUE(interest && interest->focus);
  ASSERT_EQ(interest->focus->size(), 1u);
  EXPECT_EQ(interest->focus->front(), (FocusRange{"pressure", 0, 1, 0, 0.5}));
  const std::string message =
      test::error_of([] { view::parse_client_message(R"({"type":"interest","focus":"pressure:0:1~-1"})"); });
  EXPECT_EQ(message.rfind("focus: pressure:0:1~-1", 0), 0u) << message;
  EXPECT_NE(message.find("negative"), std::string::npos) << message;
}

TEST(FocusEdge, WindowFallsSmoothlyOverTheEdge) {
  EXPECT_EQ(focus_window(0, 0.2), 1.0);
  EXPECT_EQ(focus_window(0.1, 0.2), 0.5);
  EXPECT_EQ(focus_window(0.2, 0.2), 0.0);
  EXPECT_EQ(focus_window(0.3, 0.2), 0.0);
  EXPECT_EQ(focus_window(0, 0), 1.0) << "no edge: the range itself";
  EXPECT_EQ(focus_window(1e-12, 0), 0.0);
  double prev = 1;
  for (int i = 1; i <= 100; ++i) {
    const double w = focus_window(0.002 * i, 0.2);
    EXPECT_LE(w, prev) << i;
    prev = w;
  }
  EXPECT_GT(focus_window(0.001, 0.2), 0.999) << "flat where it meets the range";
}

// A node's interest: the window at the gap between the range and the node's values (the root's "x" is [0, 1]).
TEST(FocusEdge, NodeInterestIsTheWindowAtTheGap) {
  const BrickStoreReader store(shared().store);
  ASSERT_EQ(store.node_count(), 1u);
  const auto interest = [&](const char* text) {
    return node_interest(store, 0, resolve_focus(store, parse_focus(text)));
  };
  EXPECT_EQ(interest("x:0.2:0.3"), 1.0);
  EXPECT_EQ(interest("x:1.5:2"), 0.0);
  EXPECT_EQ(interest("x:1.5:2~1"), 0.5) << "a gap of half the edge";
  EXPECT_EQ(interest("x:-2:-0.5~1"), 0.5) << "below the range alike";
  EXPECT_EQ(interest("x:2:3~1"), 0.0) << "a gap of the whole edge";
  EXPECT_EQ(interest("x:1.5:2~1+y:0:1"), 0.5) << "AND: the least";
  EXPECT_EQ(interest("x:1.5:2~1+y:5:6"), 0.0);
  EXPECT_EQ(interest("x:3:4,x:1.25:2~1"), focus_window(0.25, 1)) << "OR: the greatest";
  NodeInterest outside{resolve_focus(store, parse_focus("x:1.5:2~1")), parse_roi("box:5,5,5,6,6,6")};
  EXPECT_EQ(node_interest(store, 0, outside), 0.0) << "outside the region of interest";
}

// Seen along -z in parallel projection, pixel column i sees x = (i + 0.5) / width. The brush x:0:0.4~0.2 gives
// interest 1 left of 0.4, 0 right of 0.6 and values in between: full colour, context, and a smooth blend. The old rule
// (no edge) sees one node whose range meets [0, 0.4] and draws it all in focus.
TEST(FocusEdge, BorderInsideOneNodeIsSmooth) {
  REQUIRE_GL();
  const Shared& s = shared();
  TransferFunction tf;
  tf.color_points = {{0, {0.9, 0.1, 0.1}}, {1, {0.1, 0.3, 0.9}}};
  // Translucent: a ray through the box keeps about 0.7 of the light, the context's (extinction scaled by 0.3) 0.9.
  tf.opacity_points = {{0, 0.3}, {1, 0.3}};
  tf.opacity_unit_distance = 1;
  RenderSettings rs;
  rs.width = rs.height = 50;
  rs.background = {0, 0, 0, 0};  // transparent: a pixel's alpha is the ray's opacity
  Camera cam;
  cam.focal_point = {0.5, 0.5, 0.5};
  cam.position = {0.5, 0.5, 3};
  cam.view_up = {0, 1, 0};
  cam.parallel_projection = true;
  cam.parallel_scale = 0.5;
  const CutSpec leaves{CutSpec::Kind::Leaves, 0};
  const auto draw = [&](const char* focus, const char* roi = nullptr) {
    LodOptions o;
    if (focus) o.focus = parse_focus(focus);
    if (roi) o.roi = parse_roi(roi);
    LodEngine e(s.store, *s.gl, o);
    e.set_field("x");
    return e.render(cam, tf, rs, leaves);
  };
  const Image full = draw(nullptr), context = draw("x:5:6");  // nothing meets x:5:6: all context
  const Image edged = draw("x:0:0.4~0.2"), plain = draw("x:0:0.4");
  const Image other_field = draw("y:0:0.4~0.2"), with_roi = draw("x:0:0.4~0.2", "box:-1,-1,-1,2,2,2");
  for (const Image* same : {&plain, &other_field, &with_roi})
    EXPECT_EQ(compare_images(full, *same).max_abs, 0.0) << "the node-level rule: the one node is in focus";
  ASSERT_GT(compare_images(full, context).max_abs, 0.1) << "the context must differ from the focus to judge";

  const int y = rs.height / 2;
  int blended = 0;
  double prev_share = 0;
  for (int x = 1; x < rs.width - 1; ++x) {
    const double at = (x + 0.5) / rs.width;
    // The share of the way from the full image to the context's, in opacity (alpha), which the context's scaled
    // extinction lowers.
    const float f = full.pixel(x, y)[3], c = context.pixel(x, y)[3], e = edged.pixel(x, y)[3];
    ASSERT_GT(f - c, 0.05f) << "column " << x;
    const double share = (e - f) / (c - f);
    if (at < 0.38) {
      for (int k = 0; k < 4; ++k) EXPECT_EQ(edged.pixel(x, y)[k], full.pixel(x, y)[k]) << "focus column " << x;
    } else if (at > 0.62) {
      for (int k = 0; k < 4; ++k) EXPECT_NEAR(edged.pixel(x, y)[k], context.pixel(x, y)[k], 1e-6) << "column " << x;
    } else if (at > 0.42 && at < 0.58) {
      EXPECT_GT(share, 0.01) << "column " << x << " at x = " << at;
      EXPECT_LT(share, 0.99) << "column " << x << " at x = " << at;
      blended += share > 0.01 && share < 0.99;
    }
    EXPECT_GE(share, prev_share - 1e-6) << "towards the context monotonically, column " << x;
    prev_share = share;
  }
  std::printf("columns blended between focus and context: %d\n", blended);
  EXPECT_GE(blended, 6);
}

}  // namespace
}  // namespace ugvr
