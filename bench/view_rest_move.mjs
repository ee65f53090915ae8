// A move that arrives while the viewer draws a resting frame (full quality, the hybrid engine's exact batches): how
// long until the page shows it. Usage: node --experimental-websocket bench/view_rest_move.mjs WS_URL [WIDTH=512]
// [HEIGHT=512] [MOVES=10] [DELAY_MS=100] [WAIT=rest] (bench/run_view_rest_move.sh starts the server and runs this).
// WAIT=moving (an MPI viewer, whose resting frame is one collective frame): the second move goes DELAY_MS after the
// first frame that reflects the first move (its moving frame), rather than after the first resting frame shown.
//
// After hello and a first converged frame, each round sends a camera move (5 degrees), waits for the first resting
// frame with exact cells that reflects it (the hybrid engine's batches, seconds each on llvmpipe), waits DELAY_MS
// more so that the next batch is under way, and sends a second move; the latency is from sending that second move to receiving the first frame that
// reflects it. Then it waits for the view to converge before the next round. Prints one JSON line: the latencies'
// median, p95 and max, and how many frames the server cut short (the status's "interrupted", absent before it
// existed).
import { rotate } from "./view_camera.mjs";
import { ViewSession, percentile } from "./view_session.mjs";
const [url, width = "512", height = "512", moves = "10", delay = "100", waitFor = "rest"] = process.argv.slice(2);
const W = Number(width), H = Number(height), MOVES = Number(moves), DELAY = Number(delay);

const view = new ViewSession(url);
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

view.run(async () => {
  view.send({ type: "hello", width: W, height: H });
  const first = await view.waitFor((st) => st.converged);
  const restSeconds = [first.st.frame_seconds];
  const latency = [];
  const answerMs = [];  // the render time of the frame that shows the second move (the rest of the latency: waiting)
  const hits = { converged_first: 0 };  // rounds whose view converged before a batch was shown: no long frame hit
  let last = first.st;
  for (let i = 0; i < MOVES; ++i) {
    view.camera = rotate(view.camera, 5);
    view.send({ type: "camera", ...view.camera });
    const a = view.accepted;
    // The resting frames that take long are the exact batches (hybrid): the move goes out once the first of them is
    // shown, DELAY_MS into the next one. A store without cells (no exact batches): DELAY_MS after the moving frame.
    const long = (st) => waitFor === "moving" || st.converged || (st.exact && st.exact.nodes > 0);
    const shown = await view.waitFor((st) => st.request >= a && long(st));
    if (shown.st.converged) hits.converged_first += 1;
    await sleep(DELAY);
    view.camera = rotate(view.camera, 5);
    view.send({ type: "camera", ...view.camera });
    const b = view.accepted;
    const answer = await view.waitFor((st) => st.request >= b);
    latency.push(answer.now - view.sentAt[b]);
    answerMs.push(answer.st.frame_seconds * 1000);
    const done = await view.waitFor((st) => st.converged && st.request === view.accepted);
    restSeconds.push(done.st.frame_seconds);
    last = done.st;
  }
  const r = (x) => (x === null ? null : Math.round(x * 10) / 10);
  console.log(JSON.stringify({
    bench: "view_rest_move", width: W, height: H, moves: MOVES, delay_ms: DELAY, wait: waitFor,
    latency_ms_p50: r(percentile(latency, 0.5)), latency_ms_p95: r(percentile(latency, 0.95)),
    latency_ms_max: r(Math.max(...latency)), answer_frame_ms_p50: r(percentile(answerMs, 0.5)), converged_frame_s_p50: r(percentile(restSeconds, 0.5)),
    interrupted: last.interrupted ?? null, engine: last.engine, converged_before_move: hits.converged_first,
  }));
  view.close();
  process.exit(0);
});
