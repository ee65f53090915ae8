// The built-in demo's first view: the field, camera, transfer function and background that `ugvr view --demo` starts
// from and scripts/demo.sh renders (it writes the same JSON to out/demo-camera.json and out/demo-tf.json;
// tests/test_first_look.cpp checks that they agree).
//
// The demo dataset (`ugvr generate --kind mixed`, src/ugvr/gen/generator.cpp) is a swept, tapered wing of root chord
// 1 and span 2 standing on a floor at z = 0, in a disc of radius 15; the free stream comes from -x at 6 degrees
// incidence, and downstream a Karman street of vortices (tubes along z, their phase drifting with height) sheds from
// the trailing edge for some 13 chords. Pressure (cp) shows all of it: suction on the wing (down to -1.8), stagnation
// at its nose (+1.1), the vortex cores (-0.1 to -0.36, weakening downstream) and a free stream at 0. The transfer
// function makes the free stream (|cp| < 0.05) transparent over a dark background: vortex cores magenta to orange,
// the wing's suction orange to pale yellow, high pressure blue to cyan. Velocity would show the wake's deficit too, but
// also the floor's boundary layer (speed 0 at z = 0, far thinner than a voxel) as an opaque sheet: pressure has no
// boundary layer, so the level-of-detail image matches the exact engine's. The camera looks from upstream, to the
// side and above, so the wing stands on the left and the street recedes to the right.
#pragma once
#include <array>

namespace ugvr::cli {

inline constexpr const char* kDemoField = "pressure";

inline constexpr const char* kDemoCameraJson =
    R"({"position": [-3.5, -9.5, 10.5], "focal_point": [4.0, 0.6, 0.4], "view_up": [0, 0, 1], "view_angle": 38})";

inline constexpr const char* kDemoTfJson = R"([{"Name": "demo pressure", "ColorSpace": "RGB",
  "RGBPoints": [-1.8, 1.0, 1.0, 0.6, -0.6, 1.0, 0.8, 0.25, -0.3, 1.0, 0.45, 0.12, -0.1, 0.7, 0.12, 0.45,
                0.0, 0.2, 0.1, 0.4, 0.1, 0.1, 0.4, 0.8, 1.2, 0.6, 0.9, 1.0],
  "Points": [-1.8, 0.9, 0.5, 0.0, -0.3, 0.65, 0.5, 0.0, -0.12, 0.3, 0.5, 0.0, -0.05, 0.0, 0.5, 0.0,
             0.06, 0.0, 0.5, 0.0, 0.2, 0.3, 0.5, 0.0, 1.2, 0.8, 0.5, 0.0],
  "ScalarOpacityUnitDistance": 0.2}])";

inline constexpr std::array<double, 4> kDemoBackground{0.02, 0.02, 0.04, 1.0};

}  // namespace ugvr::cli
