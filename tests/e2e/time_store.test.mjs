// End-to-end test of the time panel over a time store (`ugvr build SERIES --time all`, docs/time-series.md): the
// level-of-detail engine draws each step from the one octree, the slider switches the step and the image with it,
// and play walks the steps at the tab's cut (TimeCriticalRenderer::switch_time_step, the next step read ahead). Run by
// run.sh, which sets UGVR and UGVR_TIME_STORE (the 4-step wake series of time.test.mjs, built into one store).
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { canvasPixels, changedFraction, launchBrowser, openPage, startViewer, stopViewer, waitConverged, waitFor } from "./lib.mjs";

const UGVR = process.env.UGVR, STORE = process.env.UGVR_TIME_STORE;
if (!UGVR || !STORE) throw new Error("set UGVR (the ugvr binary) and UGVR_TIME_STORE (a store built with --time); run.sh does");

const CONVERGE_MS = 60_000;
let viewer, browser, page;

const time = () => page.evaluate(() => window.ugvrTime.state);
const setStep = (step) =>
  page.locator("#time .time-slider").evaluate((el, step) => {
    el.value = String(step);
    el.dispatchEvent(new Event("input", { bubbles: true }));
  }, step);

before(async () => {
  viewer = await startViewer(UGVR, STORE);
  browser = await launchBrowser();
  ({ page } = await openPage(browser, viewer.url, { viewport: { width: 640, height: 480 } }));
  await waitConverged(page, CONVERGE_MS);
});

after(async () => {
  await browser?.close();
  await stopViewer(viewer);
});

test("a time store shows its steps with the level-of-detail engine; the slider changes step and image", async () => {
  const scene = await page.evaluate(() => window.ugvrViewer.scene);
  assert.equal(scene.engine, "lod", "a time store is drawn by the level-of-detail engine");
  assert.deepEqual(scene.time.times, [0, 0.25, 0.5, 0.75], "the store's steps and times");
  const t0 = await time();
  assert.equal(t0.count, 4);
  assert.equal(t0.hidden, false, "the time panel is shown for a time store");
  // Closer to the wake, where the steps differ (the vortex street moves downstream).
  const box = await page.locator("#canvas").boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  for (let i = 0; i < 4; ++i) await page.mouse.wheel(0, -300);
  // The pressure's isosurface through the vortex cores (p = -0.1, as time.test.mjs), which move between steps.
  await page.selectOption("#mode", "iso");
  await page.locator("#iso").evaluate((el) => {
    const [lo, hi] = window.ugvrViewer.range;
    el.value = String(Math.round((1000 * (-0.1 - lo)) / (hi - lo)));
    el.dispatchEvent(new Event("input", { bubbles: true }));
  });
  let s = await waitConverged(page, CONVERGE_MS);
  assert.equal(s.status.time_step, 0, "the first frame shows step 0");
  assert.equal(s.status.engine, "lod");
  const first = await canvasPixels(page);

  await setStep(2);
  s = await waitConverged(page, CONVERGE_MS);
  assert.equal(s.status.time_step, 2, "the frame shows step 2");
  assert.equal(s.status.time, 0.5);
  assert.match(await page.locator("#status").textContent(), /^lod  step 2 \(t = 0\.5\)/);
  const f = changedFraction(first, await canvasPixels(page));
  console.log(`step 0 -> 2: ${(f * 100).toFixed(1)} % of pixels changed; cut ${s.status.cut_nodes} nodes`);
  assert.ok(f > 0.005, `another step changed the image (${f})`);

  await setStep(0);
  await waitConverged(page, CONVERGE_MS);
  const back = changedFraction(first, await canvasPixels(page));
  assert.ok(back < 0.002, `back at step 0 the image is step 0's again (${back} of pixels differ)`);
});

test("play walks the steps of the store at the tab's cut", async () => {
  const rest = await waitConverged(page, CONVERGE_MS);
  await page.uncheck("#time .time-loop");
  // A frame budget of 1 s (the slowest target the page offers): what is asserted below is that the switch keeps the
  // tab's session, and at the default 10 fps a busy machine (CI's two shared cores, a browser and the viewer) can
  // make the controller shrink the cut to the root to hold 100 ms, which says nothing about the switch (3 of 9 runs
  // failed so, step 3 drawn at 1 node). A session reset would still start the step from the root at any budget.
  await page.locator("#fps").evaluate((el) => {
    el.value = "1";
    el.dispatchEvent(new Event("input", { bubbles: true }));
  });
  await page.evaluate(() => window.ugvrTime.setRate(20));
  await page.click("#time .time-play");
  const framesBefore = rest.frames;
  await waitFor("playback to reach the last step and stop", async () => {
    const t = await time();
    return !t.playing && t.shown === 3;
  }, CONVERGE_MS, 20);
  const cuts = new Map();  // step -> the cut of its first frame drawn while playing
  for (const f of await page.evaluate(() => window.ugvrViewer.frameLog))
    if (f.n > framesBefore && f.time_step !== undefined && !cuts.has(f.time_step)) cuts.set(f.time_step, f.cut_nodes);
  console.log(`first frames seen while playing (step: cut nodes): ${[...cuts].map(([k, v]) => `${k}: ${v}`).join(", ")}`);
  for (const step of [1, 2, 3]) assert.ok(cuts.has(step), `a frame of step ${step} was shown`);
  // The session is kept across steps: a step's first frame is drawn at (about) the cut the tab had, not from the root.
  for (const [step, cut] of cuts)
    if (step > 0) assert.ok(cut > 1, `step ${step} was drawn at a cut of ${cut} nodes, not the root alone`);
  const end = await waitConverged(page, CONVERGE_MS);
  assert.equal(end.status.time_step, 3);
  assert.ok(end.status.cut_nodes >= 1 && rest.status.cut_nodes >= 1);
});
