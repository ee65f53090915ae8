// ugvr view: the browser side. Frames are rendered on the server (view_protocol.h describes the messages); this page
// only turns mouse input into camera messages and shows what comes back. Plain JS, no build step, nothing loaded
// from elsewhere.
"use strict";

const canvas = document.getElementById("canvas");
const ctx = canvas.getContext("2d");
const statusBar = document.getElementById("status");
const token = new URLSearchParams(location.search).get("token");
const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws` +
                         (token ? `?token=${encodeURIComponent(token)}` : ""));
ws.binaryType = "blob";

let camera = null;       // camera.h's JSON form, as the server sent it and we move it
let lastStatus = null;   // the status that describes the next binary frame
let cameraDirty = false; // a camera message is owed at the next animation frame (one per frame: latest wins)
let lastError = "";
let framesDrawn = 0;     // binary frames drawn so far
let drawnStatus = null;  // the status of the frame on the canvas
let messagesSent = 0;    // client messages sent (status.request counts those the server accepted)

// Read-only test hook for tests/e2e/viewer.test.mjs (headless Chromium): the current camera, the status of the frame
// on the canvas, frames drawn, messages sent and the error shown, if any. Nothing on the page uses it.
window.ugvrViewer = {
  get camera() { return camera && structuredClone(camera); },
  get status() { return drawnStatus && { ...drawnStatus }; },
  get frames() { return framesDrawn; },
  get sent() { return messagesSent; },
  get error() { return lastError; },
};

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => mul(a, 1 / Math.hypot(a[0], a[1], a[2]));
// Rodrigues: v rotated by angle about the unit axis k.
const rotate = (v, k, angle) => {
  const c = Math.cos(angle), s = Math.sin(angle);
  return add(add(mul(v, c), mul(cross(k, v), s)), mul(k, dot(k, v) * (1 - c)));
};

function send(message) {
  if (ws.readyState !== WebSocket.OPEN) return;
  ws.send(JSON.stringify(message));
  messagesSent++;
}

function canvasSize() {
  const r = canvas.getBoundingClientRect();
  const clamp = (v) => Math.max(16, Math.min(4096, Math.round(v)));
  return { width: clamp(r.width), height: clamp(r.height) };
}

function showStatus() {
  if (lastError) {
    statusBar.textContent = lastError;
    statusBar.className = "error";
    return;
  }
  statusBar.className = "";
  if (!lastStatus) return;
  const s = lastStatus;
  // The frame rate means something while frames stream; once converged the server sends nothing until the view changes.
  const rate = s.converged ? "" : `${s.fps.toFixed(1)} fps  `;
  statusBar.textContent = `${s.width}×${s.height}  ${rate}frame ${(s.frame_seconds * 1000).toFixed(0)} ms  ` +
      `cut ${s.cut_nodes} nodes (${s.visible_nodes} visible)  texel error ${s.texel_error.toFixed(2)} px  ` +
      (s.converged ? "full quality" : `scale ${s.scale.toFixed(2)}  refining…`);
}

ws.onopen = () => send({ type: "hello", ...canvasSize() });
ws.onclose = () => { lastError = "disconnected"; showStatus(); };
ws.onmessage = async (event) => {
  if (typeof event.data !== "string") {
    const status = lastStatus;
    const bitmap = await createImageBitmap(event.data);
    if (canvas.width !== bitmap.width || canvas.height !== bitmap.height) {
      canvas.width = bitmap.width;
      canvas.height = bitmap.height;
    }
    ctx.drawImage(bitmap, 0, 0);
    bitmap.close();
    drawnStatus = status;
    framesDrawn++;
    showStatus();
    return;
  }
  const m = JSON.parse(event.data);
  if (m.type === "scene") {
    camera = m.camera;
    const select = document.getElementById("preset");
    select.replaceChildren(...m.presets.map((p) => new Option(p, p, p === m.preset, p === m.preset)));
    document.title = `ugvr view: ${m.field}`;
  } else if (m.type === "status") {
    lastStatus = m;
    lastError = "";
  } else if (m.type === "error") {
    lastError = `error: ${m.message}`;
    showStatus();
  }
};

// Orbit: horizontal drag turns about view up through the focal point, vertical drag about the camera's right axis.
let drag = null;
canvas.addEventListener("pointerdown", (e) => {
  drag = { x: e.clientX, y: e.clientY };
  canvas.setPointerCapture(e.pointerId);
});
canvas.addEventListener("pointerup", () => { drag = null; });
canvas.addEventListener("pointermove", (e) => {
  if (!drag || !camera) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  drag = { x: e.clientX, y: e.clientY };
  const up = norm(camera.view_up);
  let offset = sub(camera.position, camera.focal_point);
  offset = rotate(offset, up, -dx * 0.01);
  const right = norm(cross(mul(offset, -1), up));
  const turned = rotate(offset, right, -dy * 0.01);
  // Stop short of the poles, where view up would become parallel to the view direction.
  if (Math.abs(dot(norm(turned), up)) < 0.99) offset = turned;
  camera.position = add(camera.focal_point, offset);
  camera.view_up = norm(cross(right, mul(offset, -1)));
  cameraDirty = true;
});
canvas.addEventListener("wheel", (e) => {
  e.preventDefault();
  if (!camera) return;
  const offset = sub(camera.position, camera.focal_point);
  camera.position = add(camera.focal_point, mul(offset, Math.pow(1.1, Math.sign(e.deltaY))));
  cameraDirty = true;
}, { passive: false });

function tick() {
  if (cameraDirty && camera) {
    send({ type: "camera", position: camera.position, focal_point: camera.focal_point, view_up: camera.view_up,
           view_angle: camera.view_angle });
    cameraDirty = false;
  }
  requestAnimationFrame(tick);
}
requestAnimationFrame(tick);

new ResizeObserver(() => send({ type: "resize", ...canvasSize() })).observe(canvas);
document.getElementById("preset").addEventListener("change", (e) => send({ type: "tf", preset: e.target.value }));
document.getElementById("opacity").addEventListener("input", (e) => send({ type: "tf", opacity: Number(e.target.value) }));
document.getElementById("mode").addEventListener("change", (e) => send({ type: "settings", mode: e.target.value }));
document.getElementById("full").addEventListener("click", () => send({ type: "settings", full_quality: true }));
