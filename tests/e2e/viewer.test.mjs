// End-to-end tests of the `ugvr view` browser viewer in headless Chromium (node:test + playwright-core).
// Run by run.sh (ctest ViewerE2E), which sets UGVR (the binary) and UGVR_STORE (a small store it built).
// The page's state is read through its test hook, window.ugvrViewer (web/app.js). Timeouts are generous (llvmpipe
// on a loaded 2-core CI machine) but bounded, and every wait polls for its condition.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { canvasPixels, cameraMoved, changedFraction, drag, foregroundFraction, launchBrowser, startViewer, stopViewer,
         viewerState, waitConverged, waitFor } from "./lib.mjs";

const UGVR = process.env.UGVR, STORE = process.env.UGVR_STORE;
if (!UGVR || !STORE) throw new Error("set UGVR (the ugvr binary) and UGVR_STORE (a .ugvr store); run.sh does");

const FIRST_FRAME_MS = 5_000;  // the bound for a first non-blank image
const CONVERGE_MS = 60_000;    // full quality after input stops
const VIEWPORT = { width: 1000, height: 700 };

let viewer, browser, context, page;


async function openViewerPage() {
  const p = await context.newPage();
  p.on("pageerror", (e) => console.error(`page error: ${e.message}`));
  await p.goto(viewer.url);
  return p;
}

before(async () => {
  viewer = await startViewer(UGVR, STORE);
  browser = await launchBrowser();
  context = await browser.newContext({ viewport: VIEWPORT });
});

after(async () => {
  await browser?.close();
  await stopViewer(viewer);
});

test("the page loads and shows a non-blank image within 5 s", async () => {
  const start = Date.now();
  page = await openViewerPage();
  await waitFor("a non-blank frame", async () => {
    const s = await viewerState(page);
    return s && s.frames > 0 && foregroundFraction(await canvasPixels(page)) > 0.01;
  }, FIRST_FRAME_MS);
  console.log(`first non-blank frame after ${Date.now() - start} ms`);
  const s = await viewerState(page);
  assert.equal(s.error, "");
  assert.ok(s.camera, "the scene message gave a camera");
});

test("a mouse drag rotates the view", async () => {
  const before = await waitConverged(page, CONVERGE_MS);
  const pixels = await canvasPixels(page);
  await drag(page, 150, 40);
  const afterDrag = await waitConverged(page, CONVERGE_MS);
  assert.ok(cameraMoved(before.camera, afterDrag.camera), "the camera moved");
  assert.ok(afterDrag.frames > before.frames, "new frames arrived");
  const changed = changedFraction(pixels, await canvasPixels(page));
  console.log(`drag: ${(changed * 100).toFixed(1)} % of pixels changed`);
  assert.ok(changed > 0.01, `the image changed (${(changed * 100).toFixed(2)} % of pixels)`);
});

test("transfer-function edits change the image", async () => {
  let before = await waitConverged(page, CONVERGE_MS);
  let pixels = await canvasPixels(page);
  const presets = await page.locator("#preset option").evaluateAll((os) => os.map((o) => o.value));
  const current = await page.locator("#preset").inputValue();
  const other = presets.find((p) => p !== current);
  assert.ok(other, `the scene offers more than one colour map (${presets.join(", ")})`);
  await page.selectOption("#preset", other);
  let s = await waitConverged(page, CONVERGE_MS);
  assert.ok(s.sent > before.sent, "the colour map change was sent");
  let changed = changedFraction(pixels, await canvasPixels(page));
  console.log(`colour map ${current} -> ${other}: ${(changed * 100).toFixed(1)} % of pixels changed`);
  assert.ok(changed > 0.01, `a new colour map (${current} -> ${other}) changed the image (${changed} of pixels)`);

  before = s;
  pixels = await canvasPixels(page);
  await page.locator("#opacity").evaluate((el) => {
    el.value = "0.05";
    el.dispatchEvent(new Event("input", { bubbles: true }));
  });
  s = await waitConverged(page, CONVERGE_MS);
  assert.ok(s.sent > before.sent, "the opacity change was sent");
  changed = changedFraction(pixels, await canvasPixels(page));
  console.log(`opacity 1 -> 0.05: ${(changed * 100).toFixed(1)} % of pixels changed`);
  assert.ok(changed > 0.01, `opacity 0.05 changed the image (${changed} of pixels)`);
  assert.equal(s.error, "");
});

test("the status bar reaches full quality after input stops", async () => {
  await drag(page, -80, 0);
  const start = Date.now();
  await waitFor("'full quality' in the status bar", async () =>
    /full quality/.test(await page.locator("#status").textContent()), CONVERGE_MS);
  console.log(`full quality ${Date.now() - start} ms after the drag`);
  const text = await page.locator("#status").textContent();
  assert.doesNotMatch(text, /^error|disconnected/);
});

test("two tabs render independently", async () => {
  const second = await openViewerPage();
  try {
    const a0 = await waitConverged(page, CONVERGE_MS);
    const b0 = await waitConverged(second, CONVERGE_MS);
    const bPixels = await canvasPixels(second);
    // The first tab was turned and recoloured above; the second starts from the store's initial view.
    assert.ok(cameraMoved(a0.camera, b0.camera), "the tabs have different cameras");

    await drag(second, 0, 120);
    const b1 = await waitConverged(second, CONVERGE_MS);
    assert.ok(cameraMoved(b0.camera, b1.camera), "the drag turned the second tab");
    assert.ok(changedFraction(bPixels, await canvasPixels(second)) > 0.01, "the second tab's image changed");

    const aPixels = await canvasPixels(page);
    await drag(page, 100, 0);
    const a1 = await waitConverged(page, CONVERGE_MS);
    assert.ok(cameraMoved(a0.camera, a1.camera), "the drag turned the first tab");
    const b2 = await viewerState(second);
    assert.deepEqual(b2.camera, b1.camera, "turning the first tab left the second's camera alone");
    assert.equal(b2.frames, b1.frames, "the second tab got no frames from the first's change");
    assert.ok(changedFraction(aPixels, await canvasPixels(page)) > 0.01, "the first tab's image changed");
  } finally {
    await second.close();
  }
});

test("a malformed WebSocket message gets an error reply and the server keeps serving", async () => {
  // A second socket of our own: garbage first, then a message of a known type with a bad field.
  const replies = await page.evaluate(() => new Promise((resolve, reject) => {
    const ws = new WebSocket(`ws://${location.host}/ws`);
    const got = [];
    const timer = setTimeout(() => { ws.close(); resolve(got); }, 20_000);
    ws.onerror = () => { clearTimeout(timer); reject(new Error("WebSocket error")); };
    ws.onopen = () => {
      ws.send("{this is not JSON");
      ws.send(JSON.stringify({ type: "camera", position: "up" }));
    };
    ws.onmessage = (e) => {
      got.push(e.data);
      if (got.length === 2) { clearTimeout(timer); ws.close(); resolve(got); }
    };
  }));
  assert.equal(replies.length, 2, `two replies (${JSON.stringify(replies)})`);
  for (const r of replies) {
    const m = JSON.parse(r);
    assert.equal(m.type, "error", r);
    assert.equal(typeof m.message, "string");
  }
  assert.match(JSON.parse(replies[0]).message, /^message:/);

  // Garbage on the page's own socket: the page shows the error, and its session goes on.
  const before = await waitConverged(page, CONVERGE_MS);
  await page.evaluate(() => ws.send("\u0000garbage"));  // `ws`: app.js's socket (a global lexical binding)
  await waitFor("the error in the status bar", async () =>
    /^error: message/.test(await page.locator("#status").textContent()), 20_000);

  await drag(page, -120, 30);
  const s = await waitConverged(page, CONVERGE_MS);
  assert.ok(s.frames > before.frames, "new frames after the drag");
  assert.ok(cameraMoved(before.camera, s.camera), "the camera moved");
  assert.equal(s.error, "", "a new frame cleared the error");
  assert.match(await page.locator("#status").textContent(), /full quality/);
});
