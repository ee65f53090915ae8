// End-to-end tests of the viewer page's controls (web/): the transfer-function editor, field picker, clip plane,
// background colour, camera pan / reset, file save and load, PNG export, frame-rate settings, status and progress. Run by run.sh after
// viewer.test.mjs, against its own `ugvr view` of the same store (fields pressure and velocity).
import assert from "node:assert/strict";
import { readFile } from "node:fs/promises";
import { after, before, test } from "node:test";
import { cameraMoved, canvasPixels, changedFraction, drag, launchBrowser, openPage, startViewer, stopViewer, viewerState, waitConverged, waitFor } from "./lib.mjs";

const UGVR = process.env.UGVR, STORE = process.env.UGVR_STORE;
if (!UGVR || !STORE) throw new Error("set UGVR (the ugvr binary) and UGVR_STORE (a .ugvr store); run.sh does");

const CONVERGE_MS = 60_000;
const VIEWPORT = { width: 720, height: 520 };  // small: fewer pixels to converge on llvmpipe (CI time)

let viewer, browser, context, page;

const hook = (expr) => page.evaluate(`window.ugvrViewer.${expr}`);
const lastSent = async (type, key) => (await hook("log")).filter((m) => m.type === type && key in m).pop();
const setRange = (selector, value) =>
  page.locator(selector).evaluate((el, v) => {
    el.value = String(v);
    el.dispatchEvent(new Event("input", { bubbles: true }));
  }, value);
// Loads a file through an <input type=file>; a good file is sent (read asynchronously): waits until it is.
async function loadFile(selector, file) {
  const before = (await viewerState(page)).sent;
  await page.setInputFiles(selector, file);
  await waitFor(`${selector} sent`, async () => (await viewerState(page)).sent > before, 10_000);
}
const sameCamera = (a, b) =>
  ["position", "focal_point", "view_up"].every((k) => a[k].every((v, i) => Math.abs(v - b[k][i]) <= 1e-9 * (1 + Math.abs(v))));

before(async () => {
  // `--tf viridis`: the preset's ramp (two points) over the whole domain, which these tests edit and look at. Without
  // --tf the page starts from the auto transfer function, framed on what it leaves visible (viewer.test.mjs tests it).
  viewer = await startViewer(UGVR, STORE, ["--tf", "viridis"]);
  browser = await launchBrowser();
  ({ context, page } = await openPage(browser, viewer.url, { viewport: VIEWPORT, acceptDownloads: true }));
  await waitConverged(page, CONVERGE_MS);
});

after(async () => {
  await browser?.close();
  await stopViewer(viewer);
});

test("dragging an opacity point in the TF editor changes the image", async () => {
  const before = await waitConverged(page, CONVERGE_MS);
  const pixels = await canvasPixels(page);
  const tf0 = await hook("tf");
  assert.equal(tf0.opacity_points.length, 4, "the preset's ramp: two points");
  // The ramp's top point [max, 1] dragged down to about a tenth of the opacity.
  const p = await page.evaluate(() => window.ugvrViewer.tfPointPage(1));
  const box = await page.locator("#tf").boundingBox();
  await page.mouse.move(p.x, p.y);
  await page.mouse.down();
  for (let i = 1; i <= 8; ++i) await page.mouse.move(p.x, p.y + ((box.y + box.height * 0.7 - p.y) * i) / 8);
  await page.mouse.up();
  const s = await waitConverged(page, CONVERGE_MS);
  const tf1 = await hook("tf");
  assert.ok(tf1.opacity_points[3] < 0.5, `the point moved down (${tf1.opacity_points})`);
  const sent = await lastSent("tf", "opacity_points");
  assert.deepEqual(sent.opacity_points, tf1.opacity_points, "the page sent its points");
  assert.ok(s.sent - before.sent <= 9, `at most one message per move (${s.sent - before.sent})`);
  assert.equal(s.error, "");
  const changed = changedFraction(pixels, await canvasPixels(page));
  console.log(`opacity point dragged: ${(changed * 100).toFixed(1)} % of pixels changed`);
  assert.ok(changed > 0.01, `the image changed (${changed})`);

  // A click on empty space adds a point, a double-click removes it again.
  const b = await page.locator("#tf").boundingBox();
  await page.mouse.click(b.x + b.width * 0.3, b.y + b.height * 0.2);
  assert.equal((await hook("tf")).opacity_points.length, 6, "a point was added");
  const q = await page.evaluate(() => window.ugvrViewer.tfPointPage(1));
  await page.mouse.dblclick(q.x, q.y);
  await waitFor("the added point removed", async () => (await hook("tf")).opacity_points.length === 4, 5_000);
});

test("the field picker switches the field", async (t) => {
  const fields = await hook("fields");
  console.log(`fields: ${JSON.stringify(fields)}`);
  if (fields.length < 2) {
    // LEAD: the server lists only the engine's field until view_server fills SceneInfo.fields with every field.
    t.skip(`the scene lists ${fields.length} field(s): view_server does not fill SceneInfo.fields yet`);
    return;
  }
  assert.ok(fields.every((f) => f.bins > 0), "every field comes with a histogram");
  const before = await waitConverged(page, CONVERGE_MS);
  const pixels = await canvasPixels(page);
  const other = fields.find((f) => f.name !== before.field && f.name !== "pressure") ?? fields[1];
  await page.selectOption("#field", other.name);
  const s = await waitConverged(page, CONVERGE_MS);
  assert.equal(s.error, "", "the server accepted the field");
  assert.equal(await hook("field"), other.name);
  assert.deepEqual((await lastSent("settings", "field")).field, other.name);
  assert.deepEqual(await hook("range"), other.range, "the editor shows the new field's range");
  const tf = await hook("tf");
  assert.deepEqual(tf.opacity_points, [other.range[0], 0, other.range[1], 1], "points reset to the preset's ramp");
  const changed = changedFraction(pixels, await canvasPixels(page));
  console.log(`field -> ${other.name}: ${(changed * 100).toFixed(1)} % of pixels changed`);
  assert.ok(changed > 0.01, `the image shows the new field (${changed})`);

  // An unknown field is refused by the server with the list of fields.
  await page.evaluate(() => ws.send(JSON.stringify({ type: "settings", field: "no-such-field" })));
  await waitFor("the unknown-field error", async () => /no field "no-such-field"/.test(await hook("error")), 10_000);
  await page.selectOption("#field", fields[0].name);
  await waitConverged(page, CONVERGE_MS);
});

test("a clip plane changes the image and turning it off restores it", async () => {
  await waitConverged(page, CONVERGE_MS);
  const pixels = await canvasPixels(page);
  await page.check("#clip");
  let s = await waitConverged(page, CONVERGE_MS);
  const clip = (await lastSent("settings", "clip")).clip;
  assert.ok(clip && clip.normal[0] === 1, `a clip plane across x was sent (${JSON.stringify(clip)})`);
  assert.equal(s.error, "");
  const clipped = changedFraction(pixels, await canvasPixels(page));
  console.log(`clip on: ${(clipped * 100).toFixed(1)} % of pixels changed`);
  assert.ok(clipped > 0.01, `clipping changed the image (${clipped})`);
  await page.click("#clip-flip");
  s = await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSent("settings", "clip")).clip.normal[0], -1, "flip turns the normal");
  await page.uncheck("#clip");
  s = await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSent("settings", "clip")).clip, null, "clip off sends null");
  const restored = changedFraction(pixels, await canvasPixels(page));
  assert.ok(restored < 0.002, `clip off restored the image (${restored} of pixels differ)`);
});

test("isosurface mode and its value slider change the image", async () => {
  // The speed: its isosurfaces are the wing's wake, large in the initial view (the pressure's hug the small wing).
  await page.selectOption("#field", "velocity:magnitude");
  await waitConverged(page, CONVERGE_MS);
  const volume = await canvasPixels(page);
  await page.selectOption("#mode", "iso");
  await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSent("settings", "mode")).mode, "iso");
  const iso = await canvasPixels(page);
  const surface = changedFraction(volume, iso);
  console.log(`isosurface mode: ${(surface * 100).toFixed(1)} % of pixels changed`);
  assert.ok(surface > 0.01, `the isosurface differs from the volume (${surface})`);
  const v0 = await hook("iso");
  await setRange("#iso", 250);  // a quarter of the way up the field's range
  const s = await waitConverged(page, CONVERGE_MS);
  const sent = (await lastSent("settings", "iso_value")).iso_value;
  assert.ok(Math.abs(sent - (await hook("iso"))) < 1e-9 && sent < v0, `a lower iso value was sent (${sent} < ${v0})`);
  assert.equal(s.error, "");
  const moved = changedFraction(iso, await canvasPixels(page));
  console.log(`iso value ${v0.toPrecision(4)} -> ${sent.toPrecision(4)}: ${(moved * 100).toFixed(1)} % of pixels changed`);
  assert.ok(moved > 0.01, `another iso value, another surface (${moved})`);
  // The surface's reconstruction (docs/tricubic.md): the tricubic B-spline draws a smoother surface, trilinear again
  // the same image.
  const trilinear = await canvasPixels(page);
  await page.selectOption("#interpolation", "tricubic");
  await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSent("settings", "interpolation")).interpolation, "tricubic");
  const smooth = changedFraction(trilinear, await canvasPixels(page));
  console.log(`tricubic: ${(smooth * 100).toFixed(1)} % of pixels changed`);
  assert.ok(smooth > 0.001, `the tricubic surface differs from the trilinear one (${smooth})`);
  await page.selectOption("#interpolation", "trilinear");
  await waitConverged(page, CONVERGE_MS);
  assert.ok(changedFraction(trilinear, await canvasPixels(page)) < 0.002, "trilinear again draws the same image");
  await page.selectOption("#mode", "ea");
  await waitConverged(page, CONVERGE_MS);
  assert.ok(changedFraction(volume, await canvasPixels(page)) < 0.002, "back to the volume");
  await page.selectOption("#field", "pressure");
  await waitConverged(page, CONVERGE_MS);
});

test("the boundary overlay slider draws the mesh boundary; 0 removes it", async () => {
  await waitConverged(page, CONVERGE_MS);
  const plain = await canvasPixels(page);
  await setRange("#boundary", 0.6);
  let s = await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSent("settings", "boundary_opacity")).boundary_opacity, 0.6);
  assert.equal(s.error, "");
  const drawn = changedFraction(plain, await canvasPixels(page));
  console.log(`boundary overlay 0.6: ${(drawn * 100).toFixed(1)} % of pixels changed`);
  assert.ok(drawn > 0.05, `the boundary covers the mesh's silhouette (${drawn})`);
  await setRange("#boundary", 0);
  s = await waitConverged(page, CONVERGE_MS);
  assert.ok(changedFraction(plain, await canvasPixels(page)) < 0.002, "overlay 0 restores the image");
});

test("the background colour picker repaints the background; the default colour restores it", async () => {
  await waitConverged(page, CONVERGE_MS);
  const plain = await canvasPixels(page);
  const setColor = (v) =>
    page.locator("#background").evaluate((el, v) => {
      el.value = v;
      el.dispatchEvent(new Event("input", { bubbles: true }));
    }, v);
  await setColor("#ffffff");
  let s = await waitConverged(page, CONVERGE_MS);
  assert.deepEqual((await lastSent("settings", "background")).background, [1, 1, 1]);
  assert.equal(s.error, "");
  const white = await canvasPixels(page);
  assert.deepEqual(Array.from(white.slice(0, 3)), [255, 255, 255], "the corner shows the new background");
  const changed = changedFraction(plain, white);
  console.log(`background white: ${(changed * 100).toFixed(1)} % of pixels changed`);
  assert.ok(changed > 0.2, `the background covers much of the view (${changed})`);
  await setColor("#52576e");  // the default, ParaView's (0.32, 0.34, 0.43), to the picker's 8 bits
  s = await waitConverged(page, CONVERGE_MS);
  assert.ok(changedFraction(plain, await canvasPixels(page)) < 0.002, "the default colour restores the image");
});

test("touch: one finger orbits, two fingers pinch to zoom", async () => {
  const c0 = (await waitConverged(page, CONVERGE_MS)).camera;
  const box = await page.locator("#canvas").boundingBox();
  const cx = box.x + box.width / 2, cy = box.y + box.height / 2;
  // Touch pointer events as a touch screen delivers them (pointerType "touch", one pointerId per finger).
  const touch = (type, id, x, y) =>
    page.locator("#canvas").dispatchEvent(type, { pointerId: id, pointerType: "touch", isPrimary: id === 1,
                                                 clientX: x, clientY: y, button: 0, buttons: type === "pointerup" ? 0 : 1,
                                                 bubbles: true });
  await touch("pointerdown", 1, cx, cy);
  for (let i = 1; i <= 6; ++i) await touch("pointermove", 1, cx + i * 15, cy);
  await touch("pointerup", 1, cx + 90, cy);
  const c1 = (await waitConverged(page, CONVERGE_MS)).camera;
  assert.ok(cameraMoved(c0, c1), "one finger turned the camera");
  const dist = (c) => Math.hypot(...c.position.map((v, i) => v - c.focal_point[i]));
  assert.ok(Math.abs(dist(c1) - dist(c0)) < 1e-6 * dist(c0), "orbiting keeps the distance");
  // Two fingers moving apart: zoom in (the camera comes closer to the focal point).
  await touch("pointerdown", 1, cx - 20, cy);
  await touch("pointerdown", 2, cx + 20, cy);
  for (let i = 1; i <= 6; ++i) {
    await touch("pointermove", 1, cx - 20 - i * 15, cy);
    await touch("pointermove", 2, cx + 20 + i * 15, cy);
  }
  await touch("pointerup", 1, cx - 110, cy);
  await touch("pointerup", 2, cx + 110, cy);
  const c2 = (await waitConverged(page, CONVERGE_MS)).camera;
  assert.ok(dist(c2) < 0.8 * dist(c1), `the pinch zoomed in (${dist(c1).toFixed(3)} -> ${dist(c2).toFixed(3)})`);
  await page.click("#reset");
  await waitConverged(page, CONVERGE_MS);
});

test("pan moves the focal point; reset view restores the scene's camera", async () => {
  const c0 = (await waitConverged(page, CONVERGE_MS)).camera;
  await drag(page, 80, 0, { shift: true });
  const c1 = (await waitConverged(page, CONVERGE_MS)).camera;
  assert.ok(c1.focal_point.some((v, i) => Math.abs(v - c0.focal_point[i]) > 1e-6), "shift-drag moved the focal point");
  const d0 = c0.position.map((v, i) => v - c0.focal_point[i]), d1 = c1.position.map((v, i) => v - c1.focal_point[i]);
  assert.ok(d0.every((v, i) => Math.abs(v - d1[i]) < 1e-6 * (1 + Math.abs(v))), "pan keeps the view direction and distance");
  await drag(page, 0, -60, { button: "right" });
  const c2 = (await waitConverged(page, CONVERGE_MS)).camera;
  assert.ok(c2.focal_point.some((v, i) => Math.abs(v - c1.focal_point[i]) > 1e-6), "right-drag pans too");

  await drag(page, 120, 50);
  const moved = (await waitConverged(page, CONVERGE_MS)).camera;
  const home = await hook("sceneCamera");
  assert.ok(cameraMoved(home, moved), "the drag moved the camera away from the scene's");
  await page.click("#reset");
  const s = await waitConverged(page, CONVERGE_MS);
  assert.ok(sameCamera(s.camera, home), "reset view restores the scene's camera");
  assert.ok(sameCamera((await lastSent("camera", "position")), home), "and sends it");
});

test("camera and transfer function save and load round-trip; bad files are refused", async () => {
  await drag(page, 60, 20);
  const saved = (await waitConverged(page, CONVERGE_MS)).camera;
  let [download] = await Promise.all([page.waitForEvent("download"), page.click("#save-camera")]);
  const cameraPath = await download.path();
  const file = JSON.parse(await readFile(cameraPath, "utf8"));
  assert.ok(sameCamera(file, saved), "the file holds the camera");
  assert.equal(typeof file.view_angle, "number");
  await drag(page, -150, 40);
  assert.ok(cameraMoved(saved, (await waitConverged(page, CONVERGE_MS)).camera));
  await loadFile("#load-camera-file", cameraPath);
  const s = await waitConverged(page, CONVERGE_MS);
  assert.ok(sameCamera(s.camera, saved), "loading the file restored the camera");
  assert.ok(sameCamera(await lastSent("camera", "position"), saved), "and sent it");

  // A broken file: an error in the status bar and nothing sent.
  const sent = (await viewerState(page)).sent;
  await page.setInputFiles("#load-camera-file", { name: "bad.json", mimeType: "application/json", buffer: Buffer.from("{oops") });
  await waitFor("the file error", async () => /^error: camera file: not valid JSON/.test(await page.locator("#status").textContent()), 5_000);
  await page.setInputFiles("#load-tf-file", { name: "bad.json", mimeType: "application/json",
                                              buffer: Buffer.from('[{"Name":"x","RGBPoints":[0,1,1]}]') });
  await waitFor("the TF file error", async () => /RGBPoints/.test(await page.locator("#status").textContent()), 5_000);
  assert.equal((await viewerState(page)).sent, sent, "nothing was sent for the bad files");

  // TF: ParaView's preset form over the field's range; loading it sends explicit points.
  [download] = await Promise.all([page.waitForEvent("download"), page.click("#save-tf")]);
  const tfPath = await download.path();
  const tf = JSON.parse(await readFile(tfPath, "utf8"));
  assert.ok(Array.isArray(tf) && tf.length === 1 && Array.isArray(tf[0].RGBPoints) && Array.isArray(tf[0].Points));
  const range = await hook("range");
  assert.equal(tf[0].RGBPoints[0], range[0]);
  assert.equal(tf[0].RGBPoints[tf[0].RGBPoints.length - 4], range[1]);
  await loadFile("#load-tf-file", tfPath);
  const t2 = await waitConverged(page, CONVERGE_MS);
  assert.equal(t2.error, "");
  const m = await lastSent("tf", "rgb_points");
  assert.deepEqual(m.rgb_points, tf[0].RGBPoints);
  assert.equal(m.opacity_points.length, (tf[0].Points.length / 4) * 2);
  assert.ok((await hook("tf")).explicitColors);
  await page.selectOption("#preset", "viridis");  // back to the preset
  await waitConverged(page, CONVERGE_MS);
});

test("save PNG downloads the converged view at the canvas size", async () => {
  await drag(page, 40, 0);
  // Clicked while refining: the page asks for full quality and saves the converged frame.
  const [download] = await Promise.all([page.waitForEvent("download", { timeout: CONVERGE_MS }), page.click("#save-png")]);
  const bytes = await readFile(await download.path());
  assert.deepEqual([...bytes.subarray(0, 8)], [0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a], "a PNG signature");
  const size = await page.evaluate(() => [document.getElementById("canvas").width, document.getElementById("canvas").height]);
  assert.equal(bytes.toString("ascii", 12, 16), "IHDR");
  assert.deepEqual([bytes.readUInt32BE(16), bytes.readUInt32BE(20)], size, "the canvas size");
  assert.match(download.suggestedFilename(), /\.png$/);
});

test("target fps and the full-quality toggle send their settings", async () => {
  await setRange("#fps", 30);
  await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSent("settings", "fps")).fps, 30);
  await page.check("#full-toggle");
  await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSent("settings", "fps")).fps, 0, "full quality on every frame: fps 0");
  const { sent: sentAt, frames: framesAt } = await viewerState(page);
  await drag(page, 100, 30);
  await waitConverged(page, CONVERGE_MS);
  // The frames drawn since, of views after the toggle (every message before the drag reflected).
  const frames = (await hook("frameLog")).filter((f) => f.n > framesAt && f.request >= sentAt);
  assert.ok(frames.length > 0, "frames arrived during the drag");
  assert.ok(frames.every((f) => f.converged && f.format === "png"), `every frame at full quality (${JSON.stringify(frames)})`);
  await page.uncheck("#full-toggle");
  await waitConverged(page, CONVERGE_MS);
  assert.equal((await lastSent("settings", "fps")).fps, 30, "off: the slider's rate again");
  const text = await page.locator("#status").textContent();
  assert.match(text, /MiB/, "the status bar shows cache use");
  assert.match(text, /^lod /, "and the engine");
});

test("progress lines and a second scene message (a background build finishing)", async () => {
  const before = await waitConverged(page, CONVERGE_MS);
  // The server's messages, delivered to the page's own handler (`ws`: app.js's socket).
  const deliver = (m) => page.evaluate((text) => ws.onmessage({ data: text }), JSON.stringify(m));
  // Loading a grid (issue 24): reading, the walk mesh, then the store's build, with the server's reason when the grid
  // is over the memory budget.
  await deliver({ type: "progress", stage: "read", label: "reading big.vtu", fraction: 0.17, message: "reading the grid" });
  assert.match(await page.locator("#progress").textContent(), /reading 17%/);
  await deliver({ type: "progress", stage: "build", label: "walk mesh", fraction: 0, message: "" });
  assert.match(await page.locator("#progress").textContent(), /building walk mesh/);
  await deliver({ type: "progress", stage: "build", label: "cells to disk", fraction: 0.5,
                  message: "over the memory budget of 11.8 GiB" });
  assert.match(await page.locator("#progress").textContent(),
               /building store: cells to disk 50%.*over the memory budget of 11\.8 GiB/);
  await deliver({ type: "progress", stage: "build", label: "bricks", fraction: 0.42, message: "" });
  assert.match(await page.locator("#progress").textContent(), /building store: bricks 42%/);
  assert.equal(await page.locator("#progress").isVisible(), true);
  await deliver({ type: "progress", stage: "ready", label: "", fraction: 1, message: "" });
  assert.equal(await page.locator("#progress").isVisible(), false, "ready hides the progress line");
  // Edits the page holds, then the same scene again: they are kept and sent again.
  await setRange("#boundary", 0.5);
  await page.selectOption("#mode", "iso");
  await waitConverged(page, CONVERGE_MS);
  const camera = (await viewerState(page)).camera;
  const sentBefore = (await viewerState(page)).sent;
  const scene = await hook("scene");
  await deliver(scene);
  const s = await waitConverged(page, CONVERGE_MS);
  assert.equal(await hook("scenes"), 2);
  assert.ok(sameCamera(s.camera, camera), "the page kept its camera");
  const resent = (await hook("log")).slice(-(s.sent - sentBefore));
  const settings = resent.find((m) => m.type === "settings");
  assert.ok(resent.some((m) => m.type === "camera"), "the camera was sent again");
  assert.ok(resent.some((m) => m.type === "tf"), "the transfer function was sent again");
  assert.equal(settings.mode, "iso");
  assert.equal(settings.boundary_opacity, 0.5);
  assert.equal(s.error, "");
  await deliver({ type: "progress", stage: "failed", label: "", fraction: 0, message: "disk full" });
  assert.match(await page.locator("#progress").textContent(), /disk full/);
  assert.ok(before.frames > 0);
});
