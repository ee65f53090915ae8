// Camera vocabulary shared by every rendering engine, with ParaView's fields and VTK's conventions so that a camera
// written by ugvr can be typed into ParaView (and back) and frame the data the same way.
//  - position, focal_point, view_up: world coordinates; the view direction is focal_point - position.
//  - view_angle: the VERTICAL field of view in degrees (vtkCamera::ViewAngle, UseHorizontalViewAngle off).
//  - parallel_projection / parallel_scale: orthographic projection whose view height is 2 * parallel_scale.
// JSON form (camera_to_json / camera_from_json):
//   {"position": [x,y,z], "focal_point": [x,y,z], "view_up": [x,y,z], "view_angle": 30,
//    "parallel_projection": false, "parallel_scale": 1}
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>

#include "ugvr/core/vec.h"

namespace ugvr {

struct Camera {
  // vtkCamera's defaults: at +z looking at the origin, +y up.
  Vec3d position{0, 0, 1};
  Vec3d focal_point{0, 0, 0};
  Vec3d view_up{0, 1, 0};
  double view_angle = 30;  // degrees, vertical
  bool parallel_projection = false;
  double parallel_scale = 1;

  // Unit vector from position to focal point.
  Vec3d direction() const;
  double distance() const { return length(focal_point - position); }
  bool operator==(const Camera&) const = default;
};

Vec3d normalized(Vec3d v);

// Frames `bounds` as vtkRenderer::ResetCamera does: the focal point is the bounds centre; the bounding sphere
// (radius = half the diagonal, 0.5 for a single point) fits the view angle exactly, so the camera sits at
// distance = radius / sin(view_angle / 2) against `direction`; parallel_scale = radius. `up` is orthogonalised
// against the direction. Throws ugvr::Error for empty bounds, a zero direction or an up parallel to it.
Camera reset_camera(const Bounds& bounds, double view_angle = 30, Vec3d direction = {0, 0, -1}, Vec3d up = {0, 1, 0});

// The first view of a dataset (ugvr render without --camera/--view, the public API's default_request, the viewer): a
// three-quarter oblique view framed on `bounds` as reset_camera does, +z up, from the -x -y side and about 29 degrees
// above the xy plane (looking along (0.6, 0.8, -0.55)). Face-on views (ParaView's default, along -z) show most
// datasets as a flat slab; simulation data is mostly z-up (a floor, a plate, a post standing on it), and an oblique
// view shows its depth. Throws as reset_camera.
Camera default_camera(const Bounds& bounds, double view_angle = 30);

// ParaView's "Set view direction" buttons followed by a reset: "+x" looks along +x (camera on the -x side), and so
// on; view up is +z for the ±x and ±y views and +y for the ±z views. "iso" is ParaView's isometric view: the -z
// view turned 45° in azimuth and 35.264° in elevation, i.e. looking along (-1,-1,-1) with +y (orthogonalised) up.
// Throws ugvr::Error naming the accepted presets for any other name.
Camera camera_preset(std::string_view name, const Bounds& bounds, double view_angle = 30);

nlohmann::json camera_to_json(const Camera& camera);
// Reads and validates: every number finite; position != focal_point; view_up not parallel to the view direction;
// view_angle in (0, 180); parallel_scale > 0. position, focal_point and view_up are required, the rest default as
// in Camera. Unknown keys are rejected (they are typos). Errors are "SOURCE: key "K": what is wrong".
Camera camera_from_json(const nlohmann::json& json, std::string_view source);
Camera read_camera(const std::string& path);
void write_camera(const std::string& path, const Camera& camera);

struct Ray {
  Vec3d origin;
  Vec3d direction;  // unit length
};

// Primary rays of a width x height image. Pixel (x, y) has y = 0 at the TOP row and its centre at (x + 0.5, y + 0.5).
// The image plane spans the vertical view angle (perspective) or 2 * parallel_scale (parallel) from the top edge to
// the bottom edge, and aspect = width / height horizontally, as in VTK.
//  - perspective: every ray starts at the camera position;
//  - parallel: rays start on the plane through the camera position perpendicular to the view direction (the
//    near plane of a camera without clipping range) and all have the view direction.
class CameraRays {
 public:
  CameraRays(const Camera& camera, int width, int height);

  // Ray through the continuous image point (px, py) in pixel units (0..width, 0..height, y down).
  Ray at(double px, double py) const;
  Ray pixel(int x, int y) const { return at(x + 0.5, y + 0.5); }

  int width() const { return width_; }
  int height() const { return height_; }
  Vec3d forward() const { return forward_; }
  Vec3d right() const { return right_; }
  Vec3d up() const { return up_; }
  // Half extents of the image plane: at unit distance (perspective) or in world units (parallel).
  double half_width() const { return half_width_; }
  double half_height() const { return half_height_; }

 private:
  Camera camera_;
  int width_, height_;
  Vec3d forward_, right_, up_;  // orthonormal camera frame
  double half_height_;          // tan(angle/2) at unit distance (perspective) or parallel_scale (parallel)
  double half_width_;
};

}  // namespace ugvr
