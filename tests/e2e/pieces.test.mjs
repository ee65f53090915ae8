// `ugvr view INDEX.json` in one process (src/cli/cmd_view.cpp, run_view_pieces): a partitioned store's pieces drawn by
// the viewer itself, no mpirun, compared with a viewer of the same mesh's whole store; and one the viewer builds itself
// when the disk is short of scratch for one out-of-core build. Run by run.sh, which sets UGVR,
// UGVR_PIECES (an index of 2 pieces built from the e2e mesh) and UGVR_STORE (that mesh's whole store, same options).
import assert from "node:assert/strict";
import { execFileSync } from "node:child_process";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { after, before, test } from "node:test";
import { canvasPixels, cameraMoved, changedFraction, drag, foregroundFraction, launchBrowser, startViewer, stopViewer,
         waitConverged, waitFor } from "./lib.mjs";

const UGVR = process.env.UGVR, PIECES = process.env.UGVR_PIECES, STORE = process.env.UGVR_STORE;
if (!UGVR || !PIECES || !STORE) throw new Error("set UGVR, UGVR_PIECES (an index) and UGVR_STORE; run.sh does");

const CONVERGE_MS = 120_000;
const VIEWPORT = { width: 720, height: 520 };  // small: every converged frame is drawn on llvmpipe (CI time)
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

// A mesh over the memory budget whose one out-of-core build's scratch does not fit the cache's disk
// ($UGVR_SCRATCH_FREE_BYTES lowers the free space the viewer and the builder see): the viewer builds its partitioned
// store into the cache, one piece at a time, saying so in the page with the pieces' progress, then draws the index;
// a second viewer of the same mesh shows that index at once (src/cli/cmd_view.cpp, view_in_pieces).
test("too little scratch for one out-of-core build: the viewer builds pieces into the cache and shows them",
     async () => {
  const dir = mkdtempSync(join(tmpdir(), "ugvr-e2e-scratch-"));
  const saved = { cache: process.env.UGVR_CACHE_DIR, free: process.env.UGVR_SCRATCH_FREE_BYTES };
  let v;
  try {
    const mesh = join(dir, "tets.vtu");
    execFileSync(UGVR, ["--quiet", "generate", "--cells", "50000", "--kind", "tet", "-o", mesh]);
    // 50,688 cells: the whole build needs 2 x 50,688 x 96 bytes (9.7 MB) of scratch; with 3.5 MB free, 8 pieces (about
    // 3.0 MB each, as view/scratch_pieces.h estimates them; 4 would need 4.8 MB).
    process.env.UGVR_CACHE_DIR = join(dir, "cache");
    process.env.UGVR_SCRATCH_FREE_BYTES = "3500000";
    // Over the memory budget (137 MiB estimated against 64 MiB); the tabs get their own memory (a tab's RAM cache
    // takes --ram-memory, 1 GiB, and its canvas needs more).
    const args = ["--memory-budget", "64MiB", "--tabs-memory", "2GiB", "--fields", "pressure", "--tf", "viridis"];
    v = await startViewer(UGVR, mesh, args);
    const p = await browser.newPage({ viewport: VIEWPORT });
    p.on("pageerror", (e) => console.error(`page error: ${e.message}`));
    const progress = [];
    p.on("websocket", (ws) => ws.on("framereceived", (f) => {
      if (typeof f.payload === "string" && f.payload.includes('"type":"progress"'))
        progress.push(JSON.parse(f.payload));
    }));
    await p.goto(v.url);
    const s = await waitConverged(p, 3 * CONVERGE_MS);
    const building = progress.filter((m) => m.stage === "build");
    assert.ok(building.length > 0, `the page was told of the build (${JSON.stringify(progress)})`);
    assert.match(building[0].message, /not enough scratch for one build .*: building 8 pieces, one at a time/);
    assert.ok(building.some((m) => /piece \d of 8/.test(m.message)),
              `the pieces' progress (${JSON.stringify(building)})`);
    assert.equal(s.error, "");
    assert.equal(s.status.engine, "lod");
    assert.ok(foregroundFraction(await canvasPixels(p)) > 0.01, "the pieces draw the volume");
    const cache = JSON.parse(execFileSync(UGVR, ["cache", "--json"]).toString());
    assert.equal(cache.stores.length, 1);
    assert.match(cache.stores[0].path, /\.json$/, "the index is the cache's entry");
    await p.close();
    await stopViewer(v);

    v = await startViewer(UGVR, mesh, args);
    await waitFor("the cached index reported", async () => /partitioned store built earlier/.test(v.log()) || null,
                  30_000, 100);
  } finally {
    await stopViewer(v);
    process.env.UGVR_CACHE_DIR = saved.cache ?? "";
    process.env.UGVR_SCRATCH_FREE_BYTES = saved.free ?? "";
    if (saved.cache === undefined) delete process.env.UGVR_CACHE_DIR;
    if (saved.free === undefined) delete process.env.UGVR_SCRATCH_FREE_BYTES;
    rmSync(dir, { recursive: true, force: true });
  }
});
