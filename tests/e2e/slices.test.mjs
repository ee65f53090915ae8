// End-to-end test of the viewer's cutting planes (web/slices.js, docs/slices.md): adding a plane, moving it along its
// normal, hiding the volume behind it and removing it each change the image (and removing restores it). Run by run.sh
// against its own `ugvr view` of the store.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { cameraMoved, canvasPixels, changedFraction, launchBrowser, openPage, startViewer, stopViewer, waitConverged } from "./lib.mjs";

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
  // --tf viridis: the preset's ramp fills the volume, so that hiding it behind a plane shows. With the default (auto:
  // the free stream transparent) what is left covers too few pixels for "hiding the volume changed the image".
  viewer = await startViewer(UGVR, STORE, ["--tf", "viridis"]);
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

// Dragging a plane on the canvas (web/slices.js canvasDrag, "drag planes on the view"): the drag that starts on the
// plane moves it along its normal (the camera stays), shift-drag turns it, and a drag that misses it still orbits.
test("dragging a plane on the canvas moves and turns it, not the camera", async () => {
  await page.selectOption("#slices .slice-axis", "z");
  await page.click("#slices .slice-add");
  await page.check("#slices .slice-drag");
  await waitConverged(page, CONVERGE_MS);
  const before = await canvasPixels(page);
  const camera0 = await page.evaluate(() => window.ugvrViewer.camera);
  const plane0 = (await slices()).planes[0];
  const slider0 = Number(await page.locator("#slices .slice-position").first().inputValue());
  const at = await page.evaluate(() => window.ugvrSlices.planeOnCanvas(document.getElementById("canvas"), 0));
  assert.ok(at, "the plane is on the canvas");
  await page.mouse.move(at.x, at.y);
  await page.mouse.down();
  for (let i = 1; i <= 10; ++i) await page.mouse.move(at.x, at.y - 4 * i);
  assert.ok((await slices()).dragging, "the drag took the plane");
  await page.mouse.up();
  await waitConverged(page, CONVERGE_MS);
  const plane1 = (await slices()).planes[0];
  const slider1 = Number(await page.locator("#slices .slice-position").first().inputValue());
  assert.ok(!cameraMoved(camera0, await page.evaluate(() => window.ugvrViewer.camera)), "the camera stayed");
  assert.ok(Math.abs(plane1.point[2] - plane0.point[2]) > 1e-6, `the plane moved (${plane0.point} -> ${plane1.point})`);
  assert.deepEqual(plane1.normal, plane0.normal, "along its normal");
  assert.notEqual(slider1, slider0, "the panel's position slider followed");
  assert.deepEqual((await lastSlices()).slices[0].point, plane1.point, "the page sent where it is");
  const moved = await canvasPixels(page);
  const f = changedFraction(before, moved);
  console.log(`plane dragged on the canvas: ${(f * 100).toFixed(1)} % of pixels changed`);
  assert.ok(f > 0.005, `dragging the plane changed the image (${f})`);

  // Shift: turns it.
  const at2 = await page.evaluate(() => window.ugvrSlices.planeOnCanvas(document.getElementById("canvas"), 0));
  await page.mouse.move(at2.x, at2.y);
  await page.keyboard.down("Shift");
  await page.mouse.down();
  for (let i = 1; i <= 10; ++i) await page.mouse.move(at2.x + 3 * i, at2.y);
  await page.mouse.up();
  await page.keyboard.up("Shift");
  await waitConverged(page, CONVERGE_MS);
  const plane2 = (await slices()).planes[0];
  assert.ok(Math.abs(plane2.normal[2] - 1) > 1e-3, `shift-drag turned the plane (${plane2.normal})`);
  assert.ok(!cameraMoved(camera0, await page.evaluate(() => window.ugvrViewer.camera)), "the camera stayed");

  // A drag from the canvas corner misses the plane: the camera orbits as before.
  const box = await page.locator("#canvas").boundingBox();
  await page.mouse.move(box.x + 3, box.y + 3);
  await page.mouse.down();
  for (let i = 1; i <= 10; ++i) await page.mouse.move(box.x + 3 + 4 * i, box.y + 3);
  await page.mouse.up();
  assert.ok(cameraMoved(camera0, await page.evaluate(() => window.ugvrViewer.camera)), "a drag off the plane orbits");
  await page.uncheck("#slices .slice-drag");
  await page.click("#slices .slice-remove");
  await waitConverged(page, CONVERGE_MS);
});
