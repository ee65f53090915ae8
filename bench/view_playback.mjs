// Playback in `ugvr view` of a time series (issue 18): a WebSocket client that plays the steps as the page's time
// panel does (web/time_panel.js) but with the step changing on every frame: after hello and a first converged frame
// it sends {"type":"time","step":i+1,"playing":true} once the frame of step i has arrived and it is time, looping over
// the steps. PACING "shown" (the page's, default): 1/RATE s after the frame of step i arrived, less the time a step's
// frame takes to come back (averaged), so that frames arrive 1/RATE apart; "asked" (the page's before 2026-11-27):
// 1/RATE s after step i was asked for. Measured: the time between frames that show a new step (what a
// user sees as the playback's frame time; the server may send refinement frames of a step in between, counted
// apart), the server's frame time of those frames (status.frame_seconds), their image scale and, for a brick store,
// their cut (nodes, texel error in pixels). Prints one JSON line (ms).
// Usage: node --experimental-websocket bench/view_playback.mjs WS_URL [SECONDS=30] [SIZE=512] [RATE=10] [PACING=shown]
const [url, secondsArg = "30", sizeArg = "512", rateArg = "10", pacing = "shown"] = process.argv.slice(2);
if (pacing !== "shown" && pacing !== "asked") throw new Error(`PACING must be shown or asked, not ${pacing}`);
const SECONDS = Number(secondsArg), SIZE = Number(sizeArg), RATE = Number(rateArg);
const ws = new WebSocket(url);
ws.binaryType = "arraybuffer";
let count = 0, status = null, step = 0, started = false, t0 = 0, lastStep = 0, lastNewStep = 0;
const frameMs = [], gapMs = [], cutNodes = [], texelErrors = [], scales = [];
let shownBefore = -1, refinements = 0;
let latency = 0;  // ms from asking for a step to its frame, averaged (PACING shown)

const pct = (xs, q, digits = 1) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? Number(s[Math.min(s.length - 1, Math.floor(q * (s.length - 1) + 0.5))].toFixed(digits)) : null;
};

function next(now) {
  step = (step + 1) % count;
  lastStep = now;
  ws.send(JSON.stringify({ type: "time", step, playing: true }));
}

ws.onopen = () => ws.send(JSON.stringify({ type: "hello", width: SIZE, height: SIZE }));
ws.onmessage = (ev) => {
  const now = performance.now();
  if (typeof ev.data === "string") {
    const m = JSON.parse(ev.data);
    if (m.type === "scene" && m.time) count = m.time.count;
    else if (m.type === "status") status = m;
    else if (m.type === "error") console.error("server error:", m.message);
    return;
  }
  if (!status) return;
  if (!started) {
    if (!status.converged || !count) return;
    if (count < 2) {
      console.log(JSON.stringify({ error: "the scene has no time axis of two or more steps" }));
      process.exit(1);
    }
    started = true;
    t0 = now;
    lastNewStep = now;
    shownBefore = status.time_step;
    next(now);
    return;
  }
  if (status.time_step === shownBefore) {
    refinements += 1;  // another frame of the step already shown
  } else {
    frameMs.push(1000 * status.frame_seconds);
    if (status.cut_nodes) cutNodes.push(status.cut_nodes), texelErrors.push(status.texel_error);
    scales.push(status.scale ?? 1);
    gapMs.push(now - lastNewStep);
    lastNewStep = now;
    shownBefore = status.time_step;
    if (status.time_step === step) latency = latency > 0 ? 0.7 * latency + 0.3 * (now - lastStep) : now - lastStep;
  }
  if (now - t0 > SECONDS * 1000) {
    const target = 1000 / RATE;
    console.log(JSON.stringify({
      step_frames: frameMs.length, refinement_frames: refinements, steps: count, size: SIZE, rate: RATE,
      target_ms: target,
      frame_ms_median: pct(frameMs, 0.5), frame_ms_p95: pct(frameMs, 0.95),
      gap_ms_median: pct(gapMs, 0.5), gap_ms_p95: pct(gapMs, 0.95),
      p95_over_target: Number((pct(gapMs, 0.95) / target).toFixed(2)), pacing,
      steps_per_second: Number((frameMs.length / ((now - t0) / 1000)).toFixed(2)),
      // A brick store's step frames: how fine the cut they drew was (the exact engine reports none).
      cut_nodes_median: pct(cutNodes, 0.5), texel_error_median: pct(texelErrors, 0.5),
      // The image scale the frame was ray cast at (magnified to SIZE): the controller's other lever.
      scale_median: pct(scales, 0.5, 2), scale_p05: pct(scales, 0.05, 2),
    }));
    ws.close();
    process.exit(0);
  }
  if (status.time_step !== step) return;  // an older frame still on the wire
  const due = pacing === "shown" ? lastNewStep + 1000 / RATE - latency : lastStep + 1000 / RATE;
  const wait = Math.max(0, due - now);
  if (wait === 0) next(now);
  else setTimeout(() => next(performance.now()), wait);
};
