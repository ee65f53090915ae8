// Input-to-new-frame latency of `ugvr view` (issue 7): a WebSocket client that behaves like a dragging mouse.
// Usage: node --experimental-websocket bench/view_latency.mjs WS_URL [WIDTH=800] [HEIGHT=600] [SECONDS=15]
// (Node 20 needs the flag for its built-in WebSocket; bench/run_view_latency.sh starts the server and runs this.)
//
// After hello and a first converged frame, it sends a camera message every 16 ms (a 60 Hz mouse), rotating the
// camera about the view-up axis by 0.5 degree each. A frame's status says which of our messages it reflects
// ("request" counts the accepted client messages, view_protocol.h); its latency is the time from sending the newest
// message it reflects to receiving the frame's bytes: what a user sees between moving the mouse and the picture
// answering. Also measured: single inputs after rest (one camera message once the view has converged, to the first
// frame reflecting it). Prints one JSON line.
import { rotate } from "./view_camera.mjs";
const [url, width = "800", height = "600", seconds = "15"] = process.argv.slice(2);
const W = Number(width), H = Number(height), DURATION = Number(seconds) * 1000;

const ws = new WebSocket(url);
ws.binaryType = "arraybuffer";
const sentAt = [];  // sentAt[k]: time our k-th accepted message was sent (hello is 1)
let accepted = 0;
let camera = null;
let status = null;
let onFrame = null;  // (status, now) => void

function send(msg) {
  ws.send(JSON.stringify(msg));
  accepted += 1;
  sentAt[accepted] = performance.now();
}

const waitFor = (pred) =>
  new Promise((resolve) => {
    onFrame = (st, now) => {
      if (pred(st, now)) {
        onFrame = null;
        resolve({ st, now });
      }
    };
  });

ws.onmessage = (ev) => {
  const now = performance.now();
  if (typeof ev.data === "string") {
    const m = JSON.parse(ev.data);
    if (m.type === "scene") camera = m.camera;
    else if (m.type === "status") status = m;
    else if (m.type === "error") console.error("server error:", m.message);
    return;
  }
  if (status && onFrame) onFrame(status, now);
};

const percentile = (xs, q) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? s[Math.min(s.length - 1, Math.floor(q * (s.length - 1) + 0.5))] : null;
};

ws.onopen = async () => {
  send({ type: "hello", width: W, height: H });
  await waitFor((st) => st.converged);

  // Dragging.
  const drag = [];
  let frames = 0;
  const t0 = performance.now();
  const timer = setInterval(() => {
    camera = rotate(camera, 0.5);
    send({ type: "camera", ...camera });
  }, 16);
  await new Promise((resolve) => {
    onFrame = (st, now) => {
      frames += 1;
      if (st.request >= 2) drag.push(now - sentAt[st.request]);
      if (now - t0 > DURATION) resolve();
    };
  });
  clearInterval(timer);
  const dragSeconds = (performance.now() - t0) / 1000;

  // Single inputs after rest.
  const single = [];
  for (let i = 0; i < 10; ++i) {
    await waitFor((st) => st.converged && st.request === accepted);
    camera = rotate(camera, 5);
    send({ type: "camera", ...camera });
    const target = accepted;
    const { now } = await waitFor((st) => st.request >= target);
    single.push(now - sentAt[target]);
  }
  const r = (x) => (x === null ? null : Math.round(x * 10) / 10);
  console.log(JSON.stringify({
    bench: "view_latency", width: W, height: H, drag_seconds: r(dragSeconds), drag_frames: frames,
    drag_fps: r(frames / dragSeconds), drag_latency_ms_p50: r(percentile(drag, 0.5)),
    drag_latency_ms_p95: r(percentile(drag, 0.95)), single_latency_ms_p50: r(percentile(single, 0.5)),
    single_latency_ms_p95: r(percentile(single, 0.95)), single_samples: single.length,
  }));
  ws.close();
  process.exit(0);
};
ws.onerror = (e) => {
  console.error("websocket error", e.message || e);
  process.exit(1);
};
