// Dragging a cutting plane in `ugvr view` (issue 22; docs/slices.md): frames per second and input-to-frame latency
// while a client moves a plane along its normal with a settings message every 16 ms (a 60 Hz slider drag, as
// web/slices.js sends them), against rotating the camera with no plane (bench/view_latency.mjs's drag) and with the
// plane standing.
// Usage: node --experimental-websocket bench/slice_drag.mjs WS_URL POINT NORMAL [WIDTH=512] [HEIGHT=512] [SECONDS=10]
// POINT and NORMAL as "x,y,z" (the plane starts there and moves ±1/4 of the bounds' diagonal along the normal).
// bench/run_slices.sh's plane; bench/README.md has the command line that starts the viewer. Prints one JSON line
// (DEBUG=1: every frame's status on stderr).
const [url, pointText, normalText, width = "512", height = "512", seconds = "10"] = process.argv.slice(2);
const W = Number(width), H = Number(height), DURATION = Number(seconds) * 1000;
const P = pointText.split(",").map(Number), N0 = normalText.split(",").map(Number);
const nl = Math.hypot(...N0), N = N0.map((x) => x / nl);

const ws = new WebSocket(url);
ws.binaryType = "arraybuffer";
const sentAt = [];
let accepted = 0, camera = null, bounds = null, status = null, onFrame = null;

function send(msg) {
  ws.send(JSON.stringify(msg));
  accepted += 1;
  sentAt[accepted] = performance.now();
}
function rotate(cam, degrees) {
  const a = (degrees * Math.PI) / 180, c = Math.cos(a), s = Math.sin(a);
  const f = cam.focal_point, p = cam.position, k = cam.view_up, kn = Math.hypot(...k), u = k.map((x) => x / kn);
  const v = [p[0] - f[0], p[1] - f[1], p[2] - f[2]];
  const kxv = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
  const kv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  const r = v.map((x, i) => x * c + kxv[i] * s + u[i] * kv * (1 - c));
  return { ...cam, position: [f[0] + r[0], f[1] + r[1], f[2] + r[2]] };
}
const waitFor = (pred) => new Promise((resolve) => {
  onFrame = (st, now) => { if (pred(st, now)) { onFrame = null; resolve({ st, now }); } };
});
ws.onmessage = (ev) => {
  const now = performance.now();
  if (typeof ev.data === "string") {
    const m = JSON.parse(ev.data);
    if (m.type === "scene") camera = m.camera, bounds = m.bounds;
    else if (m.type === "status") status = m;
    else if (m.type === "error") console.error("server error:", m.message);
    return;
  }
  if (process.env.DEBUG && status) console.error(JSON.stringify({ request: status.request, accepted, converged: status.converged, scale: status.scale, frame_seconds: status.frame_seconds, fps: status.fps }));
  if (status && onFrame) onFrame(status, now);
};
const median = (xs) => { const s = [...xs].sort((a, b) => a - b); return s.length ? s[Math.floor(s.length / 2)] : null; };

// One drag of DURATION: `step(i)` sends the i-th message; frames counted, latency from the newest message reflected.
async function drag(step) {
  // At rest first (the server sends nothing more once the view has converged).
  if (!(status && status.converged && status.request === accepted))
    await waitFor((st) => st.converged && st.request === accepted);
  const first = accepted + 1, lat = [], scales = [];
  let frames = 0, i = 0;
  const t0 = performance.now();
  const timer = setInterval(() => step(i++), 16);
  await new Promise((resolve) => {
    onFrame = (st, now) => {
      if (st.request >= first) frames += 1, lat.push(now - sentAt[st.request]), scales.push(st.scale);
      if (now - t0 > DURATION) resolve();
    };
  });
  clearInterval(timer);
  const secs = (performance.now() - t0) / 1000, r = (x) => Math.round(x * 10) / 10;
  return { fps: r(frames / secs), frames, latency_ms_p50: r(median(lat)), scale_p50: median(scales) };
}

ws.onopen = async () => {
  send({ type: "hello", width: W, height: H });
  await waitFor((st) => st.converged);
  const d = Math.hypot(...bounds.max.map((x, i) => x - bounds.min[i]));
  const camera_drag = await drag(() => { camera = rotate(camera, 0.5); send({ type: "camera", ...camera }); });
  send({ type: "settings", slices: [{ point: P, normal: N }] });
  // The camera again, the plane standing: what a frame with a plane costs, apart from moving it.
  const camera_drag_with_plane = await drag(() => { camera = rotate(camera, -0.5); send({ type: "camera", ...camera }); });
  // Each message moves the plane (i + 1: the first one too; a message that changes nothing costs the converged view a
  // full-quality frame, which the drag would then wait for: bench/README.md).
  const slice_drag = await drag((i) => {
    const s = 0.25 * d * Math.sin((i + 1) / 30);
    send({ type: "settings", slices: [{ point: P.map((x, k) => x + N[k] * s), normal: N }] });
  });
  console.log(JSON.stringify({ bench: "slice_drag", width: W, height: H, seconds: DURATION / 1000, camera_drag,
                               camera_drag_with_plane, slice_drag }));
  ws.close();
  process.exit(0);
};
ws.onerror = (e) => { console.error("websocket error", e.message || e); process.exit(1); };
