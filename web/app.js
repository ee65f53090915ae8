// ugvr view: the browser side. Frames are rendered on the server (view_protocol.h describes the messages); this page
// turns input into camera, transfer-function and settings messages and shows what comes back. Plain JS, no build
// step, nothing loaded from elsewhere. vec.js, camera_controls.js, tf_editor.js and files.js are loaded before it.
"use strict";

const $ = (id) => document.getElementById(id);
const canvas = $("canvas");
const ctx = canvas.getContext("2d");
const statusBar = $("status");
const token = new URLSearchParams(location.search).get("token");
const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws` +
                         (token ? `?token=${encodeURIComponent(token)}` : ""));
ws.binaryType = "blob";

let scene = null;        // the latest scene message
let scenes = 0;          // scene messages received (a second one: the server switched engine)
let viewsReceived = 0;   // view messages received (the server moved the view: ViewServer::set_view)
let camera = null;       // camera.h's JSON form, as the server sent it and we move it
let lastStatus = null;   // the status that describes the next binary frame
let cameraDirty = false; // a camera message is owed at the next animation frame (one per frame: latest wins)
let lastError = "";
let framesDrawn = 0;     // binary frames drawn so far
let drawnStatus = null;  // the status of the frame on the canvas
let messagesSent = 0;    // client messages sent (status.request counts those the server accepted)
let acked = 0;           // the last ack's request: messages that changed nothing drawn (view_protocol.h, "ack")
let progress = null;     // the latest progress message (a store being built), null when none or done
let pngWanted = false;   // "save PNG" waits for a converged frame
let pngSaved = 0;
const sentLog = [];      // the last messages sent (for the test hook)
const drawnLog = [];     // the statuses of the last frames drawn (for the test hook)
const queued = [];       // tf and settings messages owed at the next animation frame, in order

// What the page shows and asks for (the server's ViewState mirrors it).
const view = {
  field: "",
  preset: "viridis",
  opacity: 1,
  colors: null,        // explicit colour points (a loaded TF file), flat [x, r, g, b, ...]; null: the preset's
  pointsEdited: false, // the opacity points were edited (sent); false: the start points (startPoints)
  mode: "ea",
  isoOpacity: 1,
  interpolation: "trilinear",  // the isosurfaces' reconstruction (lod engine): "trilinear" | "tricubic"
  lighting: true,
  volumeLighting: false,
  boundary: 0,
  background: null,    // [r, g, b] in [0, 1] once picked; null: the server's default
  earlyTermination: 0.99,
  sampleStep: 0,       // world units; 0: the level of detail picks it
  clip: { on: false, axis: "x", position: 0.5, flip: false },
  fps: 10,
  fullQuality: false,  // every frame at full quality (fps 0)
  engine: null,        // the engine picked on this page ("exact" | "lod" | "hybrid"); null: the scene's
  interest: null,      // the last "interest" message sent (focus + context); null: none
};

const tfEditor = new TfEditor($("tf"), () => {
  view.pointsEdited = true;
  queue({ type: "tf", opacity_points: tfEditor.flatPoints() });
});

// Read-only test hook for tests/e2e (headless Chromium). Nothing on the page uses it.
window.ugvrViewer = {
  get camera() { return camera && structuredClone(camera); },
  get sceneCamera() { return scene && structuredClone(scene.camera); },
  get status() { return drawnStatus && { ...drawnStatus }; },
  get frames() { return framesDrawn; },
  // Messages sent, and those owed at the next animation frame (a test waiting for `sent` to be reflected waits for them).
  get sent() { return messagesSent + queued.length + (cameraDirty ? 1 : 0); },
  get error() { return lastError; },
  get scenes() { return scenes; },
  get views() { return viewsReceived; },
  get fields() { return scene ? scene.fields.map((f) => ({ name: f.name, range: f.range.slice(), bins: f.histogram.length })) : []; },
  get field() { return view.field; },
  get focusBrush() {
    return { hidden: $("focus-brush-row").hidden, range: focusBrush.range && focusBrush.range.slice(), edge: focusBrush.edge(),
             second: { hidden: $("focus2-brush-row").hidden, range: focusBrush2.range && focusBrush2.range.slice() } };
  },
  get range() { return [tfEditor.lo, tfEditor.hi]; },
  get tf() {
    return { preset: view.preset, opacity: view.opacity, opacity_points: tfEditor.flatPoints(), rgb_points: currentColors(),
             edited: view.pointsEdited, explicitColors: view.colors !== null };
  },
  get mode() { return view.mode; },
  get iso() { return isoValue(); },
  get clip() { return clipPlane(); },
  get boundary() { return view.boundary; },
  get background() { return view.background && view.background.slice(); },
  get fps() { return view.fullQuality ? 0 : view.fps; },
  get progress() { return progress && { ...progress }; },
  get log() { return structuredClone(sentLog); },
  get frameLog() { return structuredClone(drawnLog); },
  get scene() { return scene && structuredClone(scene); },
  get engine() {
    return { picked: currentEngine(), options: [...$("engine").options].map((o) => o.value),
             disabled: $("engine").disabled, renderer: $("engine-renderer").textContent };
  },
  get pngSaved() { return pngSaved; },
  // Where an opacity point is drawn, in page coordinates (for tests that drag it).
  tfPointPage(i) {
    const c = $("tf"), b = c.getBoundingClientRect(), [px, py] = tfEditor.toPx(...tfEditor.points[i]);
    return { x: b.left + (px * b.width) / c.width, y: b.top + (py * b.height) / c.height };
  },
};

function send(message) {
  if (ws.readyState !== WebSocket.OPEN) return;
  ws.send(JSON.stringify(message));
  messagesSent++;
  sentLog.push(message);
  if (sentLog.length > 200) sentLog.shift();
}

// Owes a message at the next animation frame. Consecutive messages of one type merge (latest wins per key), except
// that a preset or field change, which resets the points before it, starts a new message.
function queue(message) {
  const last = queued[queued.length - 1];
  if (last && last.type === message.type && !("preset" in message) && !("field" in message)) Object.assign(last, message);
  else queued.push({ ...message });
}

function canvasSize() {
  const r = canvas.getBoundingClientRect();
  const clamp = (v) => Math.max(16, Math.min(4096, Math.round(v)));
  return { width: clamp(r.width), height: clamp(r.height) };
}

// ---- the field, its range and the transfer function ----

const fieldInfo = (name) => scene && scene.fields.find((f) => f.name === name);
function fieldRange() {
  const f = fieldInfo(view.field);
  const [lo, hi] = f ? f.range : scene ? scene.range : [0, 1];
  return hi > lo ? [lo, hi] : [lo - 0.5, lo + 0.5];  // a constant field widened, as the server does
}
// The preset's colours over the field's range (the server rescales the preset likewise).
function presetColors(name) {
  const p = (scene && scene.preset_points && scene.preset_points[name]) || [0, 0, 0, 0, 1, 1, 1, 1];
  const [lo, hi] = fieldRange();
  return p.map((v, i) => (i % 4 === 0 ? lo + v * (hi - lo) : v));
}
const currentColors = () => (view.colors ? view.colors.slice() : presetColors(view.preset));
// The opacity points a field starts from: the server's "auto" transfer function where the scene has it (`ugvr view`
// without --tf: the free stream transparent, as `ugvr render` draws with no flags), else the presets' linear ramp.
// The server starts the tab from the same points, so they need not be sent.
function startPoints() {
  const f = fieldInfo(view.field);
  if (f && f.auto_opacity && f.auto_opacity.length >= 4) {
    const pts = [];
    for (let i = 0; i + 1 < f.auto_opacity.length; i += 2) pts.push([f.auto_opacity[i], f.auto_opacity[i + 1]]);
    return pts;
  }
  const [lo, hi] = fieldRange();
  return [[lo, 0], [hi, 1]];
}
function resetTfPoints() {
  view.colors = null;
  view.pointsEdited = false;
  tfEditor.setPoints(startPoints());
}
function showField() {
  const f = fieldInfo(view.field);
  const [lo, hi] = fieldRange();
  tfEditor.setField(lo, hi, f ? f.histogram : []);
  tfEditor.setColors(currentColors());
  $("field").value = view.field;
  document.title = `ugvr view: ${view.field}`;
  showIso();
}

function isoValue() {
  const [lo, hi] = fieldRange();
  return lo + (Number($("iso").value) / Number($("iso").max)) * (hi - lo);
}
function showIso() {
  $("iso-row").hidden = view.mode !== "iso";
  $("iso-opacity-row").hidden = view.mode !== "iso";
  $("interpolation-row").hidden = view.mode !== "iso";
  $("iso-value").textContent = Number(isoValue().toPrecision(4)).toString();
}

// ---- the clip plane ----

function clipPlane() {
  const c = view.clip;
  if (!c.on || !scene || !camera) return null;
  const lo = scene.bounds.min, hi = scene.bounds.max;
  const center = mul(add(lo, hi), 0.5);
  let normal, point;
  if (c.axis === "view") {
    normal = norm(sub(camera.focal_point, camera.position));
    // Over the extent of the bounds along the view direction.
    let a = Infinity, b = -Infinity;
    for (let k = 0; k < 8; ++k) {
      const d = dot([k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]], normal);
      a = Math.min(a, d), b = Math.max(b, d);
    }
    point = add(center, mul(normal, a + c.position * (b - a) - dot(center, normal)));
  } else {
    const i = "xyz".indexOf(c.axis);
    normal = [0, 0, 0];
    normal[i] = 1;
    point = center.slice();
    point[i] = lo[i] + c.position * (hi[i] - lo[i]);
  }
  return { point, normal: c.flip ? mul(normal, -1) : normal };
}
const queueClip = () => queue({ type: "settings", clip: clipPlane() });

// ---- the engine ----

const engineNames = { exact: "exact", lod: "level of detail", hybrid: "hybrid (exact cells at rest)" };
const currentEngine = () => view.engine ?? (scene ? scene.engine : "");
// The engines the scene offers (one while a store is built, or for a store), the one picked, and its renderer.
function showEngine() {
  const engines = scene.engines ?? [scene.engine];
  const picked = currentEngine();
  $("engine").replaceChildren(...engines.map((e) => new Option(engineNames[e] ?? e, e, e === picked, e === picked)));
  $("engine").disabled = engines.length < 2;
  $("engine-renderer").textContent = (scene.renderers && scene.renderers[picked]) || scene.renderer || "";
}

// ---- focus + context: the degree of interest (view_protocol.h "interest", docs/hybrid.md) ----

// The brushes' state beyond the inputs: the first brush's edge (null: typed, no edge) and the second brush's range.
const brushes = { edge: null, second: null /* {lo, hi, edge} on the field chosen in #focus2-field */ };
const edgeText = (edge) => (edge > 0 ? `~${+edge.toPrecision(6)}` : "");

// The focus text from the chosen field and its min / max (a missing bound: the field's), with the first brush's edge,
// then the second brush's range joined by its operator (+ and, "," or: the --focus syntax). A second range without a
// first is sent alone.
function focusFromRange() {
  const info = fieldInfo($("focus-field").value);
  let text = "";
  if (info) {
    const lo = Number.parseFloat($("focus-min").value), hi = Number.parseFloat($("focus-max").value);
    text = `${info.name}:${Number.isFinite(lo) ? lo : info.range[0]}:${Number.isFinite(hi) ? hi : info.range[1]}` +
           edgeText(brushes.edge);
  }
  const second = fieldInfo($("focus2-field").value);
  if (second && brushes.second) {
    const b = brushes.second;
    const part = `${second.name}:${+b.lo.toPrecision(6)}:${+b.hi.toPrecision(6)}${edgeText(b.edge)}`;
    text = text ? text + $("focus2-op").value + part : part;
  }
  $("focus-text").value = text;
}
function interestMessage() {
  const focus = $("focus-text").value.trim();
  const lo = $("roi-lo").value.trim(), hi = $("roi-hi").value.trim();
  return { type: "interest", focus: focus || null, roi: $("roi").checked ? `box:${lo},${hi}` : null,
           context_saturation: Number($("context-saturation").value), context_opacity: Number($("context-opacity").value) };
}

// ---- the status bar and the build progress line ----

const mib = (bytes) => (bytes / (1024 * 1024)).toFixed(0);
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
  const cache = s.ram_budget !== undefined
    ? `RAM ${mib(s.ram_bytes)}/${mib(s.ram_budget)} MiB  GPU ${mib(s.atlas_bytes)}/${mib(s.atlas_budget)} MiB  ` : "";
  const refining = s.pending_bricks ? `refining… ${s.pending_bricks} bricks pending` : "refining…";
  const time = s.time_step !== undefined ? `step ${s.time_step} (t = ${s.time})  ` : "";
  const frame = `${s.engine ?? "lod"}  ${time}${s.width}×${s.height}  ${rate}frame ${(s.frame_seconds * 1000).toFixed(0)} ms  `;
  // The exact engine has no cut, texel error or brick caches: its frames are exact, at a reduced scale while moving.
  if (s.engine === "exact") {
    statusBar.textContent = frame + (s.converged ? "full quality" : `moving  scale ${s.scale.toFixed(2)}`);
    return;
  }
  statusBar.textContent = frame +
      `cut ${s.cut_nodes} nodes (${s.visible_nodes} visible)  texel error ${s.texel_error.toFixed(2)} px  ${cache}` +
      exactText(s) + (s.converged ? "full quality" : `${refining}  scale ${s.scale.toFixed(2)}`);
}

// How much of a hybrid frame is exact (view_protocol.h, status "exact"): voxels while the view moves, then exact
// nodes batch by batch until every visible node with cells is exact or the cell budget is full.
function exactText(s) {
  if (s.engine !== "hybrid") return "";
  const e = s.exact;
  if (!e) return "voxels until the view rests  ";
  if (e.off) return `no exact cells: ${e.off}  `;
  const full = e.budget_full ? ", cell budget full" : "";
  const context = e.focus_excluded ? `, ${e.focus_excluded} context nodes` : "";
  return `exact ${e.nodes} of ${e.candidates} nodes with cells (${(100 * e.fraction).toFixed(1)}% of the cut)` +
      `${full}${context}, ${mib(e.cell_bytes)}/${mib(e.cell_budget)} MiB cells  `;
}

// The stages of loading a grid and building its store (view_protocol.h, "progress"): reading the file, the exact
// engine's walk mesh (the first image waits for it), the store's build; the server's message says the rest (why the
// store is built out of core, what the first image waits for).
function progressText(m) {
  const percent = `${Math.round(100 * (m.fraction || 0))}%`;
  if (m.stage === "read") return `reading ${percent}`;
  if (m.label === "walk mesh") return "building walk mesh";
  return `building store: ${m.label ? m.label + " " : ""}${percent}`;
}

function showProgress(m) {
  const line = $("progress");
  if (m.stage === "ready") {
    progress = null;
    line.hidden = true;
    return;
  }
  progress = { stage: m.stage, label: m.label, fraction: m.fraction, message: m.message };
  line.hidden = false;
  if (m.stage === "failed") {
    line.className = "error";
    $("progress-bar").hidden = true;
    $("progress-text").textContent = m.message;
    lastError = `error: ${m.message}`;
    showStatus();
    return;
  }
  line.className = "";
  $("progress-bar").hidden = false;
  $("progress-bar").value = Math.min(1, Math.max(0, m.fraction || 0));
  $("progress-text").textContent = progressText(m) + (m.message ? `  ${m.message}` : "");
  if (!lastStatus && !lastError) statusBar.textContent = "waiting for the first image…";
}

// ---- messages from the server ----

function fullCameraMessage() {
  return { type: "camera", position: camera.position, focal_point: camera.focal_point, view_up: camera.view_up,
           view_angle: camera.view_angle, parallel_projection: camera.parallel_projection ?? false,
           parallel_scale: camera.parallel_scale ?? 1 };
}

// After a new scene (the server switched engine): everything the page shows, so that the new engine draws it.
function resendState() {
  send(fullCameraMessage());
  const tf = { type: "tf", preset: view.preset, opacity: view.opacity };
  if (view.colors) tf.rgb_points = view.colors;
  if (view.pointsEdited) tf.opacity_points = tfEditor.flatPoints();
  const settings = { type: "settings", field: view.field, mode: view.mode, boundary_opacity: view.boundary,
                     clip: clipPlane(), fps: view.fullQuality ? 0 : view.fps, iso_opacity: view.isoOpacity,
                     lighting: view.lighting, volume_lighting: view.volumeLighting,
                     early_termination_opacity: view.earlyTermination, sample_step: view.sampleStep,
                     interpolation: view.interpolation };
  if (view.mode === "iso") settings.iso_value = isoValue();
  if (view.background) settings.background = view.background;
  send(settings);  // first: a field change resets explicit points
  send(tf);
  if (view.interest) send(view.interest);
}

function onScene(m) {
  const first = scene === null;
  scene = m;
  scenes++;
  if (first) {
    camera = structuredClone(m.camera);
    view.field = m.field;
    view.preset = m.preset;
    view.fps = Math.min(60, Math.max(1, Math.round(m.fps || 10)));
    $("fps").value = String(view.fps);
    $("fps-value").textContent = String(view.fps);
  }
  if (!m.presets.includes(view.preset)) view.preset = m.preset;
  ugvrSlices.onScene();  // slices.js: the planes' colour maps and bounds
  ugvrTime.onScene(m);   // time_panel.js: a time series' slider and playback
  view.engine = null;  // a new scene: the server moved every tab to its engine
  showEngine();
  $("preset").replaceChildren(...m.presets.map((p) => new Option(p, p, p === view.preset, p === view.preset)));
  $("field").replaceChildren(...m.fields.map((f) => new Option(f.name, f.name, false, false)));
  const focusField = $("focus-field").value;
  $("focus-field").replaceChildren(new Option("(none)", ""),
                                   ...m.fields.map((f) => new Option(f.name, f.name, f.name === focusField, f.name === focusField)));
  const focus2Field = $("focus2-field").value;
  $("focus2-field").replaceChildren(new Option("(none)", ""),
                                    ...m.fields.map((f) => new Option(f.name, f.name, f.name === focus2Field, f.name === focus2Field)));
  showFocusBrush();  // the new scene's histograms of the focus fields, or hidden when a field is gone
  const keep = !first && fieldInfo(view.field);
  if (!keep) {
    view.field = m.field;
    resetTfPoints();
  }
  if (first && m.tf) {
    // The server started with a transfer function of its own (`ugvr view --tf FILE`): the editor shows it.
    view.colors = m.tf.rgb_points.slice();
    const pts = [];
    for (let i = 0; i + 1 < m.tf.opacity_points.length; i += 2) pts.push([m.tf.opacity_points[i], m.tf.opacity_points[i + 1]]);
    tfEditor.setPoints(pts);
    view.pointsEdited = true;
  }
  showField();
  if (!first) resendState();
}

// The server moved this tab's view (ViewServer::set_view, e.g. from Python): the page takes it as its own, so that
// the next drag or edit starts from it. The server has applied it already: nothing is sent back.
function onView(m) {
  if (m.camera) {
    camera = structuredClone(m.camera);
    cameraDirty = false;
  }
  if (m.tf) {
    view.colors = m.tf.rgb_points.slice();
    const pts = [];
    for (let i = 0; i + 1 < m.tf.opacity_points.length; i += 2) pts.push([m.tf.opacity_points[i], m.tf.opacity_points[i + 1]]);
    tfEditor.setPoints(pts);
    view.pointsEdited = true;
    view.opacity = 1;
    $("opacity").value = "1";
    showField();
  }
  viewsReceived++;
}

ws.onopen = () => send({ type: "hello", ...canvasSize() });
ws.onclose = () => {
  // A grid that failed to load stops the server: its message stays, not just "disconnected".
  lastError = progress && progress.stage === "failed" ? `error: ${progress.message} (the viewer stopped)` : "disconnected";
  showStatus();
};
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
    // A frame on its way when an ack was sent shows the acknowledged messages too.
    drawnStatus = status && { ...status, request: Math.max(status.request, acked) };
    framesDrawn++;
    if (status) drawnLog.push({ n: framesDrawn, converged: status.converged, request: status.request, format: status.format,
                              time_step: status.time_step, cut_nodes: status.cut_nodes });
    if (drawnLog.length > 200) drawnLog.shift();
    showStatus();
    ugvrTime.onFrame(status);  // time_panel.js: playing moves on once this step is drawn
    if (pngWanted && drawnStatus && drawnStatus.converged && drawnStatus.request >= messagesSent) savePng();
    return;
  }
  const m = JSON.parse(event.data);
  if (m.type === "scene") {
    onScene(m);
  } else if (m.type === "status") {
    lastStatus = m;
    if (!(progress && progress.stage === "failed")) lastError = "";
  } else if (m.type === "ack") {
    acked = Math.max(acked, m.request);
    if (drawnStatus) drawnStatus = { ...drawnStatus, request: Math.max(drawnStatus.request, acked) };
    showStatus();
  } else if (m.type === "error") {
    lastError = `error: ${m.message}`;
    showStatus();
  } else if (m.type === "progress") {
    showProgress(m);
  } else if (m.type === "view") {
    onView(m);
  }
};

// ---- input ----

// A drag on the view moves a cutting plane (slices.js) or a face of the box of interest (roi_box.js) when one of
// them takes it, else the camera.
function firstGrab(...grabs) {
  let taken = null;
  return {
    down(e) {
      taken = grabs.find((g) => g.down(e)) || null;
      return taken !== null;
    },
    move(e, dx, dy) { taken?.move(e, dx, dy); },
    up(e) {
      taken?.up(e);
      taken = null;
    },
  };
}
installCameraControls(canvas, () => camera, () => { cameraDirty = true; },
                      firstGrab(ugvrSlices.canvasDrag(canvas), ugvrRoi.canvasDrag(canvas)));

function tick() {
  if (cameraDirty && camera) {
    send({ type: "camera", position: camera.position, focal_point: camera.focal_point, view_up: camera.view_up,
           view_angle: camera.view_angle });
    cameraDirty = false;
    if (view.clip.on && view.clip.axis === "view") queueClip();  // the plane faces the viewer
  }
  for (const m of queued.splice(0)) send(m);
  ugvrRoi.draw();  // the box of interest over the view, when the camera, the box or the size changed
  requestAnimationFrame(tick);
}
requestAnimationFrame(tick);

new ResizeObserver(() => send({ type: "resize", ...canvasSize() })).observe(canvas);

// The brush on the focus field's histogram: a drag sets the range and applies the focus, with the brush's smooth
// edge (FIELD:MIN:MAX~EDGE), when it ends.
const focusBrush = new FocusBrush($("focus-brush"), (lo, hi, edge) => {
  $("focus-min").value = String(+lo.toPrecision(6));
  $("focus-max").value = String(+hi.toPrecision(6));
  brushes.edge = edge;
  focusFromRange();
  $("interest-apply").click();
});
// The second brush (SimVis's brushes combined): its range joins the first's with the chosen operator.
const focusBrush2 = new FocusBrush($("focus2-brush"), (lo, hi, edge) => {
  brushes.second = { lo, hi, edge };
  focusFromRange();
  $("interest-apply").click();
});
function showFocusBrush() {
  const info = fieldInfo($("focus-field").value);
  $("focus-brush-row").hidden = !info;
  if (info) {
    focusBrush.setField(info.range[0], info.range[1], info.histogram);
    focusBrush.setRange(Number.parseFloat($("focus-min").value), Number.parseFloat($("focus-max").value));
  }
  const second = fieldInfo($("focus2-field").value);
  $("focus2-brush-row").hidden = !second;
  if (!second) brushes.second = null;
  if (second) {
    focusBrush2.setField(second.range[0], second.range[1], second.histogram);
    focusBrush2.setRange(brushes.second ? brushes.second.lo : NaN, brushes.second ? brushes.second.hi : NaN);
  }
}
$("focus2-field").addEventListener("change", () => {
  brushes.second = null;  // a new field: nothing brushed on it yet
  showFocusBrush();
  focusFromRange();
});
$("focus2-op").addEventListener("change", () => {
  focusFromRange();
  if (brushes.second) $("interest-apply").click();
});
$("focus-field").addEventListener("change", () => {
  const info = fieldInfo($("focus-field").value);
  brushes.edge = null;  // nothing brushed on the new field yet
  // A new field: the middle half of its range to start from.
  if (info) {
    const w = info.range[1] - info.range[0];
    $("focus-min").value = String(+(info.range[0] + 0.25 * w).toPrecision(6));
    $("focus-max").value = String(+(info.range[0] + 0.75 * w).toPrecision(6));
  }
  focusFromRange();
  showFocusBrush();
});
for (const id of ["focus-min", "focus-max"])
  $(id).addEventListener("change", () => {
    brushes.edge = null;  // a typed range has no edge (the text can say ~EDGE)
    focusFromRange();
    showFocusBrush();
  });
$("roi-whole").addEventListener("click", () => {
  if (!scene) return;
  $("roi-lo").value = scene.bounds.min.join(",");
  $("roi-hi").value = scene.bounds.max.join(",");
  $("roi").checked = true;
});
$("interest-apply").addEventListener("click", () => {
  view.interest = interestMessage();
  $("interest-note").textContent = view.interest.focus || view.interest.roi ? "focus set" : "";
  queue(view.interest);
});
$("interest-clear").addEventListener("click", () => {
  $("focus-field").value = "";
  $("focus2-field").value = "";
  brushes.edge = null, brushes.second = null;
  $("focus-text").value = "";
  showFocusBrush();
  $("roi").checked = false;
  view.interest = { type: "interest", focus: null, roi: null };
  $("interest-note").textContent = "";
  queue(view.interest);
});

$("engine").addEventListener("change", (e) => {
  view.engine = e.target.value;
  showEngine();
  queue({ type: "engine", engine: view.engine });
});
$("field").addEventListener("change", (e) => {
  view.field = e.target.value;
  resetTfPoints();
  $("iso").value = String(Number($("iso").max) / 2);  // an iso value in the new range: its middle
  showField();
  const m = { type: "settings", field: view.field };
  if (view.mode === "iso") m.iso_value = isoValue();
  queue(m);
});
$("preset").addEventListener("change", (e) => {
  view.preset = e.target.value;
  resetTfPoints();  // the server goes back to the start points when a preset is picked
  tfEditor.setColors(currentColors());
  queue({ type: "tf", preset: view.preset });
});
$("opacity").addEventListener("input", (e) => {
  view.opacity = Number(e.target.value);
  queue({ type: "tf", opacity: view.opacity });
});
$("mode").addEventListener("change", (e) => {
  view.mode = e.target.value;
  showIso();
  const m = { type: "settings", mode: view.mode };
  if (view.mode === "iso") m.iso_value = isoValue();
  queue(m);
});
$("iso").addEventListener("input", () => {
  showIso();
  queue({ type: "settings", iso_value: isoValue() });
});
$("interpolation").addEventListener("change", (e) => {
  view.interpolation = e.target.value;
  queue({ type: "settings", interpolation: view.interpolation });
});
$("iso-opacity").addEventListener("input", (e) => {
  view.isoOpacity = Number(e.target.value);
  queue({ type: "settings", iso_opacity: view.isoOpacity });
});
$("lighting").addEventListener("change", (e) => {
  view.lighting = e.target.checked;
  queue({ type: "settings", lighting: view.lighting });
});
$("volume-lighting").addEventListener("change", (e) => {
  view.volumeLighting = e.target.checked;
  queue({ type: "settings", volume_lighting: view.volumeLighting });
});
$("boundary").addEventListener("input", (e) => {
  view.boundary = Number(e.target.value);
  queue({ type: "settings", boundary_opacity: view.boundary });
});
$("background").addEventListener("input", (e) => {
  // "#rrggbb" -> [r, g, b] in [0, 1]
  view.background = [1, 3, 5].map((i) => parseInt(e.target.value.slice(i, i + 2), 16) / 255);
  queue({ type: "settings", background: view.background });
});
$("early-termination").addEventListener("input", (e) => {
  view.earlyTermination = Number(e.target.value);
  $("early-termination-value").textContent = String(view.earlyTermination);
  queue({ type: "settings", early_termination_opacity: view.earlyTermination });
});
$("sample-step").addEventListener("change", (e) => {
  const v = Number(e.target.value);
  if (e.target.value === "" || !Number.isFinite(v) || v < 0) {
    e.target.value = String(view.sampleStep);  // not a step: the one in use again
    return;
  }
  view.sampleStep = v;
  queue({ type: "settings", sample_step: v });
});
$("clip").addEventListener("change", (e) => { view.clip.on = e.target.checked; queueClip(); });
$("clip-axis").addEventListener("change", (e) => { view.clip.axis = e.target.value; if (view.clip.on) queueClip(); });
$("clip-pos").addEventListener("input", (e) => { view.clip.position = Number(e.target.value); if (view.clip.on) queueClip(); });
$("clip-flip").addEventListener("click", () => { view.clip.flip = !view.clip.flip; if (view.clip.on) queueClip(); });
$("fps").addEventListener("input", (e) => {
  view.fps = Number(e.target.value);
  $("fps-value").textContent = String(view.fps);
  if (!view.fullQuality) queue({ type: "settings", fps: view.fps });
});
$("full-toggle").addEventListener("change", (e) => {
  view.fullQuality = e.target.checked;
  $("fps").disabled = view.fullQuality;
  queue({ type: "settings", fps: view.fullQuality ? 0 : view.fps });
});
$("full").addEventListener("click", () => queue({ type: "settings", full_quality: true }));
$("reset").addEventListener("click", () => {
  if (!scene) return;
  camera = structuredClone(scene.camera);
  cameraDirty = true;
});

// ---- files ----

function savePng() {
  pngWanted = false;
  canvas.toBlob((blob) => {
    if (!blob) return;
    downloadBlob(blob, `ugvr-${view.field || "view"}.png`);
    pngSaved++;
  }, "image/png");
}
$("save-png").addEventListener("click", () => {
  const s = drawnStatus;
  if (s && s.converged && s.request >= messagesSent && queued.length === 0 && !cameraDirty) {
    savePng();
  } else {
    pngWanted = true;  // saved when the converged frame arrives
    queue({ type: "settings", full_quality: true });
  }
});
$("save-camera").addEventListener("click", () => { if (camera) downloadJson(camera, "camera.json"); });
$("save-tf").addEventListener("click", () => {
  // What is shown: the colours over the field's range and the opacity points times the opacity scale.
  const points = tfEditor.points.map(([x, a]) => [x, Math.min(1, a * view.opacity)]);
  downloadJson(tfFileJson(view.colors ? "ugvr" : view.preset, currentColors(), points), "transfer_function.json");
});
$("load-camera").addEventListener("click", () => $("load-camera-file").click());
$("load-tf").addEventListener("click", () => $("load-tf-file").click());
function fileError(message) {
  lastError = `error: ${message}`;
  showStatus();
}
$("load-camera-file").addEventListener("change", async (e) => {
  if (!e.target.files.length) return;
  try {
    const c = parseCameraFile(await readFileText(e.target));
    camera = { view_angle: 30, parallel_projection: false, parallel_scale: 1, ...c };
    lastError = "";
    cameraDirty = false;
    send(fullCameraMessage());
  } catch (err) {
    fileError(err.message);
  } finally {
    e.target.value = "";
  }
});
$("load-tf-file").addEventListener("change", async (e) => {
  if (!e.target.files.length) return;
  try {
    const tf = parseTfFile(await readFileText(e.target));
    lastError = "";
    view.colors = tf.rgb;
    view.pointsEdited = true;
    view.opacity = 1;  // the file's opacities are what is shown
    $("opacity").value = "1";
    tfEditor.setColors(tf.rgb);
    tfEditor.setPoints(tf.opacity);
    queue({ type: "tf", opacity: 1, rgb_points: tf.rgb, opacity_points: tfEditor.flatPoints() });
  } catch (err) {
    fileError(err.message);
  } finally {
    e.target.value = "";
  }
});
