// End-to-end test of the viewer's cutting planes (web/slices.js, docs/slices.md): adding a plane, moving it along its
// normal, hiding the volume behind it and removing it each change the image (and removing restores it). Run by run.sh
// against its own `ugvr view` of the store.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { canvasPixels, changedFraction, launchBrowser, openPage, startViewer, stopViewer, waitConverged } from "./lib.mjs";

const UGVR = process.env.UGVR, STORE = process.env.UGVR_STORE;
if (!UGVR || !STORE) throw new Error("set UGVR (the ugvr binary) and UGVR_STORE (a .ugvr store); run.sh does");

const CONVERGE_MS = 40_000;
let viewer, browser, page;

const slices = () => page.evaluate(() => window.ugvrSlices.state);
const lastSlices = async () =>
  (await page.evaluate(() => window.ugvrViewer.log)).filter((m) => m.type === "settings" && "slices" in m).pop();
const setRange = (locator, value) =>
  locator.evaluate((el, v) => {
    el.value = String(v);
    el.dispatchEvent(new Event("input", { bubbles: true }));
  }, value);

before(async () => {
  viewer = await startViewer(UGVR, STORE);
  browser = await launchBrowser();
  ({ page } = await openPage(browser, viewer.url, { viewport: { width: 720, height: 520 } }));
  await waitConverged(page, CONVERGE_MS);
});

after(async () => {
  await browser?.close();
  await stopViewer(viewer);
});

test("a plane added, moved, hiding the volume and removed changes the image each time", async () => {
  const none = await canvasPixels(page);
  await page.selectOption("#slices .slice-axis", "z");
  await page.click("#slices .slice-add");
  await waitConverged(page, CONVERGE_MS);
  const sent = await lastSlices();
  assert.equal(sent.slices.length, 1, "the page sent one plane");
  assert.ok(Math.abs(sent.slices[0].normal[2] - 1) < 1e-9, `across z (${JSON.stringify(sent.slices[0])})`);
  const added = await canvasPixels(page);
  const f1 = changedFraction(none, added);
  console.log(`plane added: ${(f1 * 100).toFixed(1)} % of pixels changed`);
  assert.ok(f1 > 0.01, `adding a plane changed the image (${f1})`);

  // Dragging the plane along its normal: the position slider, as a user drags it.
  const z0 = (await slices()).planes[0].point[2];
  await setRange(page.locator("#slices .slice-position").first(), 0.85);
  await waitConverged(page, CONVERGE_MS);
  const z1 = (await slices()).planes[0].point[2];
  assert.ok(z1 > z0, `the plane moved up its normal (${z0} -> ${z1})`);
  assert.equal((await lastSlices()).slices[0].point[2], z1, "and the page sent where it is");
  const moved = await canvasPixels(page);
  const f2 = changedFraction(added, moved);
  console.log(`plane moved: ${(f2 * 100).toFixed(1)} % of pixels changed`);
  assert.ok(f2 > 0.005, `moving the plane changed the image (${f2})`);

  await page.selectOption("#slices .slice-hide", "all");
  await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSlices()).hide_volume, "all");
  const f3 = changedFraction(moved, await canvasPixels(page));
  assert.ok(f3 > 0.01, `hiding the volume changed the image (${f3})`);

  await page.selectOption("#slices .slice-hide", "none");
  await page.click("#slices .slice-remove");
  await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSlices()).slices.length, 0, "removing sends an empty list");
  const restored = changedFraction(none, await canvasPixels(page));
  assert.ok(restored < 0.002, `removing the plane restored the image (${restored} of pixels differ)`);
});
