// The viewer's soak test (issue 23): clients that drag and clients that come and go, for a fixed time, against one
// `ugvr view`. bench/run_view_soak.sh starts the server, runs this and samples the server's RSS meanwhile.
// Usage: node --experimental-websocket bench/view_soak.mjs WS_URL SECONDS [DRAGGERS=4] [CYCLERS=2] [SIZE=512]
//
// A dragger says hello, then sends a camera message every 100 ms (a 10 Hz drag, rotating 1 degree about view-up),
// every 20 s a new transfer-function opacity and every 60 s a resize between SIZE and 3/4 SIZE, and reads every frame.
// A cycler connects, says hello, waits for its first frame, drags for 1-3 s, closes, waits 0.5 s, and again. All
// loops end at the deadline (bounded: nothing runs past SECONDS + 30 s). Prints one JSON line: frames, messages,
// connections, errors per kind.
import { rotate } from "./view_camera.mjs";
const [url, secondsArg, draggersArg = "4", cyclersArg = "2", sizeArg = "512"] = process.argv.slice(2);
const deadline = performance.now() + Number(secondsArg) * 1000;
const SIZE = Number(sizeArg);
const stats = { frames: 0, messages: 0, connections: 0, refused: 0, server_errors: 0, socket_errors: 0 };

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// One connection: resolves when it closes. `drive(ws, state)` runs once the first frame arrived.
function connect(drive) {
  return new Promise((resolve) => {
    const ws = new WebSocket(url);
    ws.binaryType = "arraybuffer";
    const state = { camera: null, firstFrame: false, closed: false };
    stats.connections += 1;
    ws.onopen = () => ws.send(JSON.stringify({ type: "hello", width: SIZE, height: SIZE }));
    ws.onmessage = (ev) => {
      if (typeof ev.data === "string") {
        const m = JSON.parse(ev.data);
        if (m.type === "scene") state.camera = m.camera;
        else if (m.type === "error") stats.server_errors += 1;
        return;
      }
      stats.frames += 1;
      if (!state.firstFrame && state.camera) {
        state.firstFrame = true;
        drive(ws, state).finally(() => ws.close());
      }
    };
    ws.onerror = () => {
      stats.socket_errors += 1;
    };
    ws.onclose = (ev) => {
      state.closed = true;
      if (!state.firstFrame && ev.code !== 1000) stats.refused += 1;
      resolve();
    };
  });
}

async function drag(ws, state, untilMs) {
  let t = 0;
  while (performance.now() < untilMs && !state.closed) {
    state.camera = rotate(state.camera, 1);
    ws.send(JSON.stringify({ type: "camera", ...state.camera }));
    stats.messages += 1;
    t += 1;
    if (t % 200 === 0) {
      ws.send(JSON.stringify({ type: "tf", opacity: 0.3 + 0.7 * Math.random() }));
      stats.messages += 1;
    }
    if (t % 600 === 0) {
      const side = (t / 600) % 2 ? Math.round((SIZE * 3) / 4) : SIZE;
      ws.send(JSON.stringify({ type: "resize", width: side, height: side }));
      stats.messages += 1;
    }
    await sleep(100);
  }
}

async function dragger() {
  while (performance.now() < deadline) await connect((ws, state) => drag(ws, state, deadline));
}

async function cycler() {
  while (performance.now() < deadline) {
    await connect((ws, state) => drag(ws, state, Math.min(deadline, performance.now() + 1000 + 2000 * Math.random())));
    await sleep(500);
  }
}

const all = [];
for (let i = 0; i < Number(draggersArg); ++i) all.push(dragger());
for (let i = 0; i < Number(cyclersArg); ++i) all.push(cycler());
const guard = setTimeout(() => {
  console.log(JSON.stringify({ ...stats, note: "stopped by the guard 30 s after the deadline" }));
  process.exit(1);
}, Number(secondsArg) * 1000 + 30000);
await Promise.all(all);
clearTimeout(guard);
console.log(JSON.stringify(stats));
