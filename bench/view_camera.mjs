// Camera moves shared by the viewer's WebSocket benchmarks (view_latency.mjs, view_soak.mjs): the camera JSON of
// src/ugvr/render/camera.h, as the scene message carries it.

// `cam` turned about its view-up axis through the focal point by `degrees` (Rodrigues' rotation of the position).
export function rotate(cam, degrees) {
  const a = (degrees * Math.PI) / 180, c = Math.cos(a), s = Math.sin(a);
  const f = cam.focal_point, p = cam.position;
  const k = cam.view_up, kn = Math.hypot(...k);
  const u = k.map((x) => x / kn);
  const v = [p[0] - f[0], p[1] - f[1], p[2] - f[2]];
  const kxv = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
  const kv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  const r = v.map((x, i) => x * c + kxv[i] * s + u[i] * kv * (1 - c));
  return { ...cam, position: [f[0] + r[0], f[1] + r[1], f[2] + r[2]] };
}
