// End-to-end test of the viewer's time panel (web/time_panel.js, docs/viewer.md): against `ugvr view SERIES` of a
// generated 4-step series (the wake's vortex street moves downstream), the slider switches the step the exact engine
// shows and the image changes; play advances through the steps to the last (loop off) and stops there. Run by run.sh.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { canvasPixels, changedFraction, launchBrowser, openPage, startViewer, stopViewer, waitConverged, waitFor } from "./lib.mjs";

const UGVR = process.env.UGVR, SERIES = process.env.UGVR_SERIES;
if (!UGVR || !SERIES) throw new Error("set UGVR (the ugvr binary) and UGVR_SERIES (a .pvd series); run.sh does");

const CONVERGE_MS = 60_000;
let viewer, browser, page;

const time = () => page.evaluate(() => window.ugvrTime.state);
const timeMessages = async () => (await page.evaluate(() => window.ugvrViewer.log)).filter((m) => m.type === "time");

before(async () => {
  viewer = await startViewer(UGVR, SERIES);
  browser = await launchBrowser();
  ({ page } = await openPage(browser, viewer.url, { viewport: { width: 720, height: 560 } }));
  await waitConverged(page, CONVERGE_MS);
});

after(async () => {
  await browser?.close();
  await stopViewer(viewer);
});

test("the slider changes the step and the image", async () => {
  const t0 = await time();
  assert.equal(t0.count, 4, "the scene lists the series' 4 steps");
  assert.equal(t0.hidden, false, "the time panel is shown for a series");
  const scene = await page.evaluate(() => window.ugvrViewer.scene);
  assert.deepEqual(scene.time.times, [0, 0.25, 0.5, 0.75], "the steps' times (t = i/N)");
  assert.deepEqual(scene.engines, ["exact"], "a series is shown by the exact engine alone");
  console.log(`field ${scene.field}; fields ${scene.fields.map((f) => `${f.name} [${f.range}]`).join(", ")}`);
  // The vortex street is small beside the whole domain (a disc of radius 15 around the wing): zoom in on the wake,
  // and show the pressure's isosurface through the vortex cores (low pressure), which move downstream between steps.
  const box = await page.locator("#canvas").boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  for (let i = 0; i < 4; ++i) await page.mouse.wheel(0, -300);
  await page.selectOption("#mode", "iso");
  // p = -0.1 (the slider spans the field's range in 1000 steps): the street's cores.
  await page.locator("#iso").evaluate((el) => {
    const [lo, hi] = window.ugvrViewer.range;
    el.value = String(Math.round((1000 * (-0.1 - lo)) / (hi - lo)));
    el.dispatchEvent(new Event("input", { bubbles: true }));
  });
  await waitConverged(page, CONVERGE_MS);
  const status0 = await page.evaluate(() => window.ugvrViewer.status);
  assert.equal(status0.time_step, 0, "the first frame shows step 0");
  const first = await canvasPixels(page);

  await page.locator("#time .time-slider").evaluate((el) => {
    el.value = "2";
    el.dispatchEvent(new Event("input", { bubbles: true }));
  });
  await waitConverged(page, CONVERGE_MS);
  const sent = (await timeMessages()).pop();
  assert.deepEqual(sent, { type: "time", step: 2, playing: false }, "the slider sent the step");
  const status = await page.evaluate(() => window.ugvrViewer.status);
  assert.equal(status.time_step, 2, "the frame shows step 2");
  assert.equal(status.time, 0.5);
  assert.equal(await page.locator("#time .time-label").textContent(), "step 3 of 4, t = 0.5");
  const f = changedFraction(first, await canvasPixels(page));
  console.log(`step 0 -> 2: ${(f * 100).toFixed(1)} % of pixels changed`);
  assert.ok(f > 0.005, `another step changed the image (${f})`);

  await page.locator("#time .time-slider").evaluate((el) => {
    el.value = "0";
    el.dispatchEvent(new Event("input", { bubbles: true }));
  });
  await waitConverged(page, CONVERGE_MS);
  const back = changedFraction(first, await canvasPixels(page));
  assert.ok(back < 0.002, `back at step 0 the image is step 0's again (${back} of pixels differ)`);
});

test("play advances through the steps and stops at the last without loop", async () => {
  await page.evaluate(() => window.ugvrTime.go(0));
  await waitConverged(page, CONVERGE_MS);
  await page.uncheck("#time .time-loop");
  await page.evaluate(() => window.ugvrTime.setRate(20));
  await page.click("#time .time-play");
  assert.equal((await time()).playing, true);
  const seen = new Set();
  await waitFor("playback to reach the last step and stop", async () => {
    const s = await page.evaluate(() => window.ugvrViewer.status);
    if (s && s.time_step !== undefined) seen.add(s.time_step);
    const t = await time();
    return !t.playing && t.shown === 3;
  }, CONVERGE_MS, 20);
  const steps = (await timeMessages()).filter((m) => m.playing).map((m) => m.step);
  console.log(`played steps sent: ${steps.join(", ")}; frames seen at steps ${[...seen].join(", ")}`);
  for (const s of [1, 2, 3]) assert.ok(steps.includes(s), `play asked for step ${s} (${steps})`);
  assert.deepEqual(steps.filter((s, i) => i > 0 && s < steps[i - 1]), [], "in order (no loop)");
  assert.equal(await page.locator("#time .time-play").textContent(), "play", "stopped at the end");
  await waitConverged(page, CONVERGE_MS);
  assert.equal((await page.evaluate(() => window.ugvrViewer.status)).time_step, 3);
});

test("ugvr view --play starts a new tab playing", async () => {
  const playing = await startViewer(UGVR, SERIES, ["--play", "20"]);
  try {
    const { context, page: p } = await openPage(browser, playing.url, { viewport: { width: 480, height: 400 } });
    const scene = await waitFor("the scene", () => p.evaluate(() => window.ugvrViewer.scene), CONVERGE_MS, 50);
    assert.equal(scene.time.play, 20, "the scene carries the rate");
    const seen = new Set();
    await waitFor("the page to play through several steps by itself", async () => {
      const s = await p.evaluate(() => window.ugvrViewer.status);
      if (s && s.time_step !== undefined) seen.add(s.time_step);
      return seen.size >= 3;
    }, CONVERGE_MS, 20);
    const t = await p.evaluate(() => window.ugvrTime.state);
    assert.equal(t.playing, true, "still playing (loop on)");
    assert.equal(await p.locator("#time .time-rate").inputValue(), "20");
    await context.close();
  } finally {
    await stopViewer(playing);
  }
});
