// Degree of interest (hybrid_select.h; docs/hybrid.md): the region of interest (`--roi box:...|sphere:...`), the
// focus's AND ('+') and OR (',') of value ranges, and their texts. The GL tests (nodes of zero interest load no cells,
// context drawn desaturated and faint) are in test_hybrid.cpp, beside the store they use.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/hybrid_select.h"
#include "ugvr/render/lod/lod_engine.h"

namespace ugvr {
namespace {

Bounds box(Vec3d lo, Vec3d hi) {
  Bounds b;
  b.lo = lo, b.hi = hi;
  return b;
}

TEST(Roi, ParsesBoxesAndSpheres) {
  const RegionOfInterest b = parse_roi("box:1,2,3,-1,0,5");
  EXPECT_EQ(b.shape, RegionOfInterest::Shape::Box);
  EXPECT_EQ(b.lo, (Vec3d{-1, 0, 3})) << "any two opposite corners";
  EXPECT_EQ(b.hi, (Vec3d{1, 2, 5}));
  const RegionOfInterest s = parse_roi("sphere:0.5,-2,1e-3,0.25");
  EXPECT_EQ(s.shape, RegionOfInterest::Shape::Sphere);
  EXPECT_EQ(s.centre, (Vec3d{0.5, -2, 1e-3}));
  EXPECT_EQ(s.radius, 0.25);
  // The text reads back to the same region.
  EXPECT_EQ(parse_roi(roi_text(b)), b);
  EXPECT_EQ(parse_roi(roi_text(s)), s);
}

TEST(Roi, BadTextNamesTheFlagAndWhatIsWrong) {
  const auto message = [](const std::string& text) {
    try {
      parse_roi(text, "--roi");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(message("cube:0,0,0,1,1,1").find("--roi cube:0,0,0,1,1,1: expected box:... or sphere:..."),
            std::string::npos)
      << message("cube:0,0,0,1,1,1");
  EXPECT_NE(message("box:0,0,0,1,1").find("a box takes 6 numbers, found 5"), std::string::npos);
  EXPECT_NE(message("sphere:0,0,0").find("a sphere takes 4 numbers, found 3"), std::string::npos);
  EXPECT_NE(message("sphere:0,0,0,0").find("the radius must be > 0"), std::string::npos);
  EXPECT_NE(message("box:0,0,0,1,1,inf").find("\"inf\" is not a finite number"), std::string::npos);
  EXPECT_NE(message("box:0,0,0,1,,1").find("\"\" is not a finite number"), std::string::npos);
  EXPECT_NE(message("box").find("expected box:... or sphere:..."), std::string::npos);
}

TEST(Roi, MeetsBoxesItTouchesOrOverlapsOnly) {
  const RegionOfInterest b = parse_roi("box:0,0,0,1,1,1");
  EXPECT_TRUE(b.meets(box({0.5, 0.5, 0.5}, {2, 2, 2})));
  EXPECT_TRUE(b.meets(box({1, 0, 0}, {2, 1, 1}))) << "touching counts";
  EXPECT_TRUE(b.meets(box({-5, -5, -5}, {5, 5, 5}))) << "inside a node";
  EXPECT_FALSE(b.meets(box({1.01, 0, 0}, {2, 1, 1})));
  EXPECT_FALSE(b.meets(box({0, 0, -2}, {1, 1, -0.5})));
  const RegionOfInterest s = parse_roi("sphere:0,0,0,1");
  EXPECT_TRUE(s.meets(box({0.5, 0.5, -0.1}, {2, 2, 2})));  // nearest point (0.5, 0.5, 0): distance 0.71
  EXPECT_FALSE(s.meets(box({0.8, 0.8, 0}, {2, 2, 2})));    // nearest point (0.8, 0.8, 0): distance 1.13
  EXPECT_TRUE(s.meets(box({-0.1, -0.1, -0.1}, {0.1, 0.1, 0.1}))) << "a node inside the sphere";
  EXPECT_FALSE(s.meets(box({1.01, -1, -1}, {2, 1, 1})));
}

TEST(Roi, FocusJoinsRangesWithPlusAsAndAndCommaAsOr) {
  const std::vector<FocusRange> f = parse_focus("pressure:0:1+velocity:magnitude:2:3,temperature:-5:9");
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(f[0], (FocusRange{"pressure", 0, 1, 0}));
  EXPECT_EQ(f[1], (FocusRange{"velocity:magnitude", 2, 3, 0}));
  EXPECT_EQ(f[2], (FocusRange{"temperature", -5, 9, 1}));
  EXPECT_EQ(parse_focus(focus_text(f)), f);
  for (const char* bad : {"p:0:1+", "+p:0:1", "p:0:1++q:0:1", "p:0:1+q:1:0", "p:0:1+q"})
    EXPECT_THROW(parse_focus(bad), Error) << bad;
}

TEST(Roi, ContextValuesAreValidated) {
  LodOptions o;
  EXPECT_NO_THROW(o.validate());
  EXPECT_EQ(o.context_saturation, 0.2);
  EXPECT_EQ(o.context_opacity, 0.3);
  o.context_saturation = 1.5;
  try {
    o.validate();
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--context-saturation"), std::string::npos) << e.what();
  }
  o.context_saturation = 0;
  o.context_opacity = -0.1;
  EXPECT_THROW(o.validate(), Error);
  o.context_opacity = 1;
  EXPECT_NO_THROW(o.validate());
}

}  // namespace
}  // namespace ugvr
