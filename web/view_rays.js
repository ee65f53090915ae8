// ugvr view: the camera's rays and projection on the view canvas, as camera.h's CameraRays (the image spans the
// vertical view angle, or 2 parallel_scale, top to bottom). Shared by what the page drags on the view: cutting planes
// (slices.js) and the region-of-interest box (roi_box.js). `rect` is the canvas's client rectangle; points on it are
// CSS pixels from its top left.
"use strict";

function cameraFrame(camera) {
  const forward = norm(sub(camera.focal_point, camera.position));
  const right = norm(cross(forward, camera.view_up));
  return { forward, right, up: cross(right, forward) };
}

// The ray through canvas point (x, y): {origin, dir}.
function viewRayAt(camera, rect, x, y) {
  const { forward, right, up } = cameraFrame(camera);
  const sx = (2 * x) / rect.width - 1, sy = 1 - (2 * y) / rect.height;
  const aspect = rect.width / rect.height;
  if (camera.parallel_projection) {
    const h = camera.parallel_scale;
    return { origin: add(camera.position, add(mul(right, sx * h * aspect), mul(up, sy * h))), dir: forward };
  }
  const h = Math.tan((camera.view_angle * Math.PI) / 360);
  return { origin: camera.position, dir: norm(add(forward, add(mul(right, sx * h * aspect), mul(up, sy * h)))) };
}

// Where world point p appears on the canvas, or null behind the camera.
function viewProject(camera, rect, p) {
  const { forward, right, up } = cameraFrame(camera);
  const d = sub(p, camera.position);
  const z = dot(d, forward);
  const h = camera.parallel_projection ? camera.parallel_scale : z * Math.tan((camera.view_angle * Math.PI) / 360);
  if (!(h > 0)) return null;
  const aspect = rect.width / rect.height;
  return [((dot(d, right) / (h * aspect) + 1) * rect.width) / 2, ((1 - dot(d, up) / h) * rect.height) / 2];
}

// A drag along world direction `axis` from world point p: the axis's unit direction on screen and screen pixels per
// world unit. Seen nearly edge-on the axis is a short vector on screen: below 1/10 of `span` per canvas height the
// drag falls back to "up moves it forward" at a canvas height per span, so that a drag never throws it across the data.
function screenAxis(camera, rect, p, axis, span) {
  const a = viewProject(camera, rect, p), b = viewProject(camera, rect, add(p, mul(axis, 1e-3 * span)));
  let dir = [0, -1], perWorld = rect.height / span;
  if (a && b) {
    const v = [(b[0] - a[0]) / (1e-3 * span), (b[1] - a[1]) / (1e-3 * span)];
    const len = Math.hypot(v[0], v[1]);
    if (len > (0.1 * rect.height) / span) dir = [v[0] / len, v[1] / len], perWorld = len;
  }
  return { dir, perWorld };
}
