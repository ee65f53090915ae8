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
import { ViewSession, percentile } from "./view_session.mjs";
const [url, width = "800", height = "600", seconds = "15"] = process.argv.slice(2);
const W = Number(width), H = Number(height), DURATION = Number(seconds) * 1000;

const view = new ViewSession(url);

view.run(async () => {
  view.send({ type: "hello", width: W, height: H });
  await view.waitFor((st) => st.converged);

  // Dragging.
  const drag = [];
  let frames = 0;
  const t0 = performance.now();
  const timer = setInterval(() => {
    view.camera = rotate(view.camera, 0.5);
    view.send({ type: "camera", ...view.camera });
  }, 16);
  await new Promise((resolve) => {
    view.onFrame = (st, now) => {
      frames += 1;
      if (st.request >= 2) drag.push(now - view.sentAt[st.request]);
      if (now - t0 > DURATION) resolve();
    };
  });
  clearInterval(timer);
  const dragSeconds = (performance.now() - t0) / 1000;

  // Single inputs after rest.
  const single = [];
  for (let i = 0; i < 10; ++i) {
    await view.waitFor((st) => st.converged && st.request === view.accepted);
    view.camera = rotate(view.camera, 5);
    view.send({ type: "camera", ...view.camera });
    const target = view.accepted;
    const { now } = await view.waitFor((st) => st.request >= target);
    single.push(now - view.sentAt[target]);
  }
  const r = (x) => (x === null ? null : Math.round(x * 10) / 10);
  console.log(JSON.stringify({
    bench: "view_latency", width: W, height: H, drag_seconds: r(dragSeconds), drag_frames: frames,
    drag_fps: r(frames / dragSeconds), drag_latency_ms_p50: r(percentile(drag, 0.5)),
    drag_latency_ms_p95: r(percentile(drag, 0.95)), single_latency_ms_p50: r(percentile(single, 0.5)),
    single_latency_ms_p95: r(percentile(single, 0.95)), single_samples: single.length,
  }));
  view.close();
  process.exit(0);
});
