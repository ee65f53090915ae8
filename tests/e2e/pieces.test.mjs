// `ugvr view INDEX.json` in one process (src/cli/cmd_view.cpp, run_view_pieces): a partitioned store's pieces drawn by
// the viewer itself, no mpirun, compared with a viewer of the same mesh's whole store. Run by run.sh, which sets UGVR,
// UGVR_PIECES (an index of 2 pieces built from the e2e mesh) and UGVR_STORE (that mesh's whole store, same options).
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { canvasPixels, cameraMoved, changedFraction, drag, foregroundFraction, launchBrowser, startViewer, stopViewer,
         waitConverged } from "./lib.mjs";

const UGVR = process.env.UGVR, PIECES = process.env.UGVR_PIECES, STORE = process.env.UGVR_STORE;
if (!UGVR || !PIECES || !STORE) throw new Error("set UGVR, UGVR_PIECES (an index) and UGVR_STORE; run.sh does");

const CONVERGE_MS = 120_000;
const VIEWPORT = { width: 1000, height: 700 };
let browser;

before(async () => { browser = await launchBrowser(); });
after(async () => { await browser?.close(); });

// The converged frame, field list and state of a fresh viewer of `input`.
async function converged(input) {
  const viewer = await startViewer(UGVR, input);
  try {
    const page = await browser.newPage({ viewport: VIEWPORT });
    page.on("pageerror", (e) => console.error(`page error: ${e.message}`));
    await page.goto(viewer.url);
    const s = await waitConverged(page, CONVERGE_MS);
    const fields = await page.evaluate(() => window.ugvrViewer.fields);
    return { page, viewer, state: s, fields, pixels: await canvasPixels(page) };
  } catch (e) {
    await stopViewer(viewer);
    throw e;
  }
}

test("a partitioned store's index opens in one process and draws what the whole store draws", async () => {
  const pieces = await converged(PIECES);
  try {
    assert.equal(pieces.state.error, "");
    assert.equal(pieces.state.status.engine, "lod");
    assert.deepEqual(pieces.fields.map((f) => f.name).sort(), ["pressure", "velocity:magnitude"]);
    assert.ok(pieces.fields.every((f) => f.bins > 0), "the pieces' histograms reach the page");
    const fg = foregroundFraction(pieces.pixels);
    assert.ok(fg > 0.05, `the volume shows (${fg})`);

    const whole = await converged(STORE);
    let differ;
    try {
      differ = changedFraction(pieces.pixels, whole.pixels);
    } finally {
      await stopViewer(whole.viewer);
    }
    console.log(`pieces vs whole store: ${(differ * 100).toFixed(1)} % of sampled pixels differ by > 2 levels`);
    assert.ok(differ < 0.02, `the pieces draw the whole store's image (${differ} of pixels differ)`);

    await drag(pieces.page, 120, 30);
    const turned = await waitConverged(pieces.page, CONVERGE_MS);
    assert.ok(cameraMoved(pieces.state.camera, turned.camera), "the camera moved");
    assert.ok(changedFraction(pieces.pixels, await canvasPixels(pieces.page)) > 0.01, "the image follows the view");
  } finally {
    await stopViewer(pieces.viewer);
  }
});
