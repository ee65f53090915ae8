// End-to-end test of the hybrid engine in the page (docs/hybrid.md): against `ugvr view STORE` of a small store built
// with `--cells`, the viewer draws with the hybrid engine by default, turns nodes exact while the view rests and says
// how many in the status bar; the engine picker goes back to voxels; the interest panel's box makes the nodes outside
// it context (no exact cells, drawn faint). Run by run.sh, which sets UGVR and UGVR_CELLS_STORE.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { canvasPixels, changedFraction, launchBrowser, openPage, startViewer, stopViewer, waitConverged, waitFor } from "./lib.mjs";

const UGVR = process.env.UGVR, STORE = process.env.UGVR_CELLS_STORE;
if (!UGVR || !STORE) throw new Error("set UGVR (the ugvr binary) and UGVR_CELLS_STORE (a store built with --cells); run.sh does");

const CONVERGE_MS = 90_000;  // the exact batches of a rest, on llvmpipe
let viewer, browser, page;

const hook = (expr) => page.evaluate(`window.ugvrViewer.${expr}`);
const statusText = () => page.locator("#status").textContent();

before(async () => {
  // --tf viridis: the preset's ramp over the whole domain's view, where the box-of-interest test finds the box's faces
  // on screen. The default (auto) frames the view on the wing and its wake, which puts the faces elsewhere.
  viewer = await startViewer(UGVR, STORE, ["--tf", "viridis"]);
  browser = await launchBrowser();
  ({ page } = await openPage(browser, viewer.url, { viewport: { width: 640, height: 480 } }));
});

after(async () => {
  await browser?.close();
  await stopViewer(viewer);
});

test("a store with cells opens in the hybrid engine and turns exact at rest", async () => {
  const scene = await waitFor("the scene", () => hook("scene"), CONVERGE_MS);
  assert.equal(scene.engine, "hybrid", "a store with cells is drawn by the hybrid engine by default");
  assert.ok(scene.engines.includes("hybrid") && scene.engines.includes("lod"), `engines ${scene.engines}`);
  const s = await waitConverged(page, CONVERGE_MS);
  assert.equal(s.status.engine, "hybrid");
  const e = s.status.exact;
  assert.ok(e, "a resting hybrid frame says how much is exact");
  console.log(`at rest: exact ${e.nodes} of ${e.candidates} nodes (${(100 * e.fraction).toFixed(1)} % of the cut)`);
  assert.ok(e.nodes > 0, "nodes turned exact at rest");
  assert.ok(e.nodes <= e.candidates);
  assert.ok(e.budget_full || e.nodes === e.candidates, "converged: every candidate exact, or the cell budget full");
  assert.match(await statusText(), /exact \d+ of \d+ nodes with cells \(\d+\.\d% of the cut\)/);
  assert.equal(s.error, "");
});

test("the engine picker draws the same view with voxels only, and back", async () => {
  const hybrid = await canvasPixels(page);
  await page.selectOption("#engine", "lod");
  let s = await waitConverged(page, CONVERGE_MS);
  assert.equal(s.status.engine, "lod");
  assert.doesNotMatch(await statusText(), /exact \d+ of/, "no exact figures for voxels");
  const voxels = await canvasPixels(page);
  const f = changedFraction(hybrid, voxels);
  console.log(`hybrid vs voxels: ${(100 * f).toFixed(2)} % of pixels differ`);
  assert.ok(f > 0, "the exact cells change the image");
  await page.selectOption("#engine", "hybrid");
  s = await waitConverged(page, CONVERGE_MS);
  assert.equal(s.status.engine, "hybrid");
  assert.ok(s.status.exact && s.status.exact.nodes > 0);
  const back = changedFraction(hybrid, await canvasPixels(page));
  assert.ok(back < 0.002, `back to the hybrid image (${back} of pixels differ)`);
});

test("a box of interest makes the rest context: fewer exact nodes, the image changes", async () => {
  const before = await waitConverged(page, CONVERGE_MS);
  const full = await canvasPixels(page);
  const scene = await hook("scene");
  // The lower half along x: the nodes of the upper half are context.
  const lo = scene.bounds.min, hi = scene.bounds.max;
  const mid = [0.5 * (lo[0] + hi[0]), hi[1], hi[2]];
  await page.fill("#roi-lo", lo.join(","));
  await page.fill("#roi-hi", mid.join(","));
  await page.check("#roi");
  await page.click("#interest-apply");
  assert.equal(await page.locator("#interest-note").textContent(), "focus set");
  const sent = await waitFor("the interest message", async () => (await hook("log")).filter((m) => m.type === "interest").pop(),
                             CONVERGE_MS);
  assert.equal(sent.roi, `box:${lo.join(",")},${mid.join(",")}`);
  await waitFor("a frame of the new interest", async () => (await hook("frames")) > before.frames, CONVERGE_MS);
  const s = await waitConverged(page, CONVERGE_MS);
  const e = s.status.exact;
  console.log(`with the box: exact ${e.nodes} of ${e.candidates}, ${e.focus_excluded} context nodes`);
  assert.ok(e.focus_excluded > 0, "nodes outside the box are context");
  assert.ok(e.nodes < before.status.exact.nodes, "fewer exact nodes than without the box");
  assert.match(await statusText(), /\d+ context nodes/);
  assert.ok(changedFraction(full, await canvasPixels(page)) > 0.01, "the context is drawn faint");

  await page.click("#interest-clear");
  const cleared = await waitConverged(page, CONVERGE_MS);
  assert.ok(!cleared.status.exact.focus_excluded, "no context without a focus");
  assert.equal(cleared.status.exact.nodes, before.status.exact.nodes, "the same exact nodes as before the box");
});

test("a brush on the focus field's histogram sets the focus when the drag ends", async () => {
  const before = await waitConverged(page, CONVERGE_MS);
  const scene = await hook("scene");
  const field = scene.fields.find((f) => f.range[1] > f.range[0]);
  assert.ok(field, "a field that varies");
  assert.equal((await hook("focusBrush")).hidden, true, "no brush before a focus field is chosen");
  await page.selectOption("#focus-field", field.name);
  const shown = await hook("focusBrush");
  assert.equal(shown.hidden, false, "the brush shows the focus field's histogram");
  const [lo, hi] = field.range, w = hi - lo;
  assert.ok(Math.abs(shown.range[0] - (lo + 0.25 * w)) < 1e-5 * w && Math.abs(shown.range[1] - (lo + 0.75 * w)) < 1e-5 * w,
            `it starts on the middle half of the range: ${shown.range}`);
  const sentBefore = (await hook("log")).filter((m) => m.type === "interest").length;
  // Drag across a fifth of the plot ending a tenth below its fullest bin (the free stream, which every node holds), so
  // that the range holds data only the nodes by the wing reach (the canvas is drawn 1:1; its plot has 4 pixels of
  // padding on each side); kept inside the plot with room for the edge handle's drag below.
  const hist = field.histogram;
  let peak = 0;
  hist.forEach((c, i) => { if (c > hist[peak]) peak = i; });
  const f0 = Math.min(Math.max(peak / hist.length - 0.3, 0.02), 0.6), f1 = f0 + 0.2;
  const box = await page.locator("#focus-brush").boundingBox();
  const at = (f) => box.x + 4 + f * (box.width - 8);
  const y = box.y + box.height / 2;
  await page.mouse.move(at(f0), y);
  await page.mouse.down();
  await page.mouse.move(at(f0 + 0.1), y, { steps: 4 });
  const during = (await hook("log")).filter((m) => m.type === "interest").length;
  assert.equal(during, sentBefore, "nothing is sent while dragging");
  await page.mouse.move(at(f1), y, { steps: 4 });
  await page.mouse.up();
  const sent = await waitFor("the brushed interest message", async () => {
    const all = (await hook("log")).filter((m) => m.type === "interest");
    return all.length > sentBefore ? all.pop() : null;
  }, CONVERGE_MS);
  const m = sent.focus.match(/^(.*):([^:]+):([^:~]+)~([^:~]+)$/);
  assert.ok(m && m[1] === field.name, `the focus names the field, with an edge: ${sent.focus}`);
  const bmin = Number(m[2]), bmax = Number(m[3]), edge = Number(m[4]);
  assert.ok(Math.abs(edge - 0.02 * w) < 1e-5 * w, `the brush's edge is a fiftieth of the range: ${edge}`);
  // Within a pixel of the drag's ends (the plot is about 290 pixels wide).
  assert.ok(Math.abs(bmin - (lo + f0 * w)) < 0.01 * w && Math.abs(bmax - (lo + f1 * w)) < 0.01 * w,
            `brushed ${bmin}..${bmax} of ${lo}..${hi}`);
  assert.equal(await page.locator("#interest-note").textContent(), "focus set");
  assert.deepEqual((await hook("focusBrush")).range.map((v) => +v.toPrecision(6)), [bmin, bmax]);
  await waitFor("a frame of the brushed focus", async () => (await hook("frames")) > before.frames, CONVERGE_MS);
  const s = await waitConverged(page, CONVERGE_MS);
  console.log(`brushed ${field.name} ${bmin}..${bmax}: exact ${s.status.exact.nodes} of ${s.status.exact.candidates}, ` +
              `${s.status.exact.focus_excluded} context nodes`);
  assert.ok(s.status.exact.focus_excluded > 0, "nodes outside the brushed range are context");
  assert.ok(s.status.exact.nodes > 0, "nodes inside the brushed range are exact");

  // A second brush on another field, ANDed (SimVis's combined brushes): its range joins the first's with "+".
  const other = scene.fields.find((f) => f.name !== field.name && f.range[1] > f.range[0]);
  assert.ok(other, "the store has a second field that varies");
  assert.equal((await hook("focusBrush")).second.hidden, true, "no second brush before its field is chosen");
  await page.selectOption("#focus2-op", "+");
  await page.selectOption("#focus2-field", other.name);
  assert.equal((await hook("focusBrush")).second.hidden, false, "the second brush shows its field's histogram");
  const sentBeforeSecond = (await hook("log")).filter((m) => m.type === "interest").length;
  await page.locator("#focus2-brush").scrollIntoViewIfNeeded();  // the panel is taller than the 640x480 view
  const box2 = await page.locator("#focus2-brush").boundingBox();
  const at2 = (f) => box2.x + 4 + f * (box2.width - 8);
  const y2 = box2.y + box2.height / 2;
  await page.mouse.move(at2(0.1), y2);
  await page.mouse.down();
  await page.mouse.move(at2(0.6), y2, { steps: 4 });
  await page.mouse.up();
  const both = await waitFor("the interest message with both brushes", async () => {
    const all = (await hook("log")).filter((m) => m.type === "interest");
    return all.length > sentBeforeSecond ? all.pop() : null;
  }, CONVERGE_MS);
  const parts = both.focus.split("+");
  assert.equal(parts.length, 2, `two ranges ANDed: ${both.focus}`);
  assert.equal(parts[0], sent.focus, "the first brush's range and edge are kept");
  const m2 = parts[1].match(/^(.*):([^:]+):([^:~]+)~([^:~]+)$/);
  const w2 = other.range[1] - other.range[0];
  assert.ok(m2 && m2[1] === other.name, `the second range names its field, with an edge: ${parts[1]}`);
  assert.ok(Math.abs(Number(m2[2]) - (other.range[0] + 0.1 * w2)) < 0.01 * w2 &&
            Math.abs(Number(m2[3]) - (other.range[0] + 0.6 * w2)) < 0.01 * w2, `brushed ${parts[1]}`);
  const s2 = await waitConverged(page, CONVERGE_MS);
  console.log(`AND of two brushes: exact ${s2.status.exact.nodes} of ${s2.status.exact.candidates}, ` +
              `${s2.status.exact.focus_excluded} context nodes`);
  // (OR would make context of fewer nodes: the second range alone meets most of them.)
  assert.ok(s2.status.exact.focus_excluded >= s.status.exact.focus_excluded, "AND leaves no fewer context nodes");
  // The second brush off again (the text keeps the first range only; applied with the next change).
  await page.selectOption("#focus2-field", "");
  assert.equal(await page.locator("#focus-text").inputValue(), sent.focus);

  // The right band's outer end is a handle: dragging it from the range's end + a fiftieth to 15 % beyond the end sets
  // the edge to about 15 % of the range (its distance from the range's end) and applies it; the range stays.
  const sentBeforeEdge = (await hook("log")).filter((m) => m.type === "interest").length;
  const handle = (bmax - lo) / w + 0.02;
  await page.mouse.move(at(handle), y);
  await page.mouse.down();
  await page.mouse.move(at(f1 + 0.15), y, { steps: 4 });
  await page.mouse.up();
  const edged = await waitFor("the interest message with the dragged edge", async () => {
    const all = (await hook("log")).filter((m) => m.type === "interest");
    return all.length > sentBeforeEdge ? all.pop() : null;
  }, CONVERGE_MS);
  const me = edged.focus.match(/^(.*):([^:]+):([^:~]+)~([^:~]+)$/);
  assert.ok(me, `the focus keeps an edge: ${edged.focus}`);
  assert.ok(Math.abs(Number(me[2]) - bmin) < 1e-4 * w && Math.abs(Number(me[3]) - bmax) < 1e-4 * w,
            `dragging the edge keeps the range: ${edged.focus}`);
  const dragged = Number(me[4]);
  assert.ok(Math.abs(dragged - (lo + (f1 + 0.15) * w - bmax)) < 0.01 * w, `the edge follows the handle: ${dragged} of ${w}`);
  assert.ok(Math.abs((await hook("focusBrush")).edge - dragged) < 1e-4 * w, "the brush draws the edge it sent");
  await waitConverged(page, CONVERGE_MS);

  await page.click("#interest-clear");
  assert.equal((await hook("focusBrush")).hidden, true, "clearing the focus hides the brush");
  assert.equal((await hook("focusBrush")).second.hidden, true, "and the second brush");
  await waitConverged(page, CONVERGE_MS);
});

test("the box of interest is dragged on the view: a face moves along its axis, the focus is applied on release", async () => {
  const before = await waitConverged(page, CONVERGE_MS);
  const scene = await hook("scene");
  await page.click("#roi-whole");
  await page.check("#roi-drag");
  const roi = (expr) => page.evaluate(`ugvrRoi.${expr}`);
  assert.equal(await roi("dragMode"), true);
  // The box is drawn over the image: its wireframe's pixels on the overlay canvas (drawn from app.js's frame loop).
  const overlayPixels = () =>
    page.evaluate(() => {
      const o = document.getElementById("roi-overlay");
      const d = o.getContext("2d").getImageData(0, 0, o.width, o.height).data;
      let n = 0;
      for (let i = 3; i < d.length; i += 4) n += d[i] > 0;
      return n;
    });
  await waitFor("the box's wireframe on the overlay", async () => (await overlayPixels()) > 200, 10_000, 100);
  // A face seen from the camera: the drag from its centre takes that face.
  let face = null, from = null;
  for (let axis = 0; axis < 3 && !face; ++axis)
    for (let side = 0; side < 2 && !face; ++side) {
      const c = await roi(`faceCentre(${axis}, ${side})`);
      const hit = c && (await roi(`faceAt(${c[0]}, ${c[1]})`));
      if (hit && hit.axis === axis && hit.side === side) face = hit, from = c;
    }
  assert.ok(face, "a face of the whole-data box is seen");
  const lo = scene.bounds.min, hi = scene.bounds.max, k = face.axis, extent = hi[k] - lo[k];
  // Drag the face's centre towards where it would be a quarter of the extent inwards.
  const centre = lo.map((v, i) => 0.5 * (v + hi[i]));
  centre[k] = face.side ? hi[k] - 0.25 * extent : lo[k] + 0.25 * extent;
  const to = await roi(`pageOf(${JSON.stringify(centre)})`);
  const sentBefore = (await hook("log")).filter((m) => m.type === "interest").length;
  const cameraBefore = await hook("camera");
  await page.mouse.move(from[0], from[1]);
  await page.mouse.down();
  await page.mouse.move(0.5 * (from[0] + to[0]), 0.5 * (from[1] + to[1]), { steps: 4 });
  assert.equal(await roi("dragging"), true, "the box took the drag, not the camera");
  assert.equal((await hook("log")).filter((m) => m.type === "interest").length, sentBefore, "nothing sent while dragging");
  await page.mouse.move(to[0], to[1], { steps: 4 });
  await page.mouse.up();
  const sent = await waitFor("the dragged box's interest message", async () => {
    const all = (await hook("log")).filter((m) => m.type === "interest");
    return all.length > sentBefore ? all.pop() : null;
  }, CONVERGE_MS);
  const m = sent.roi.match(/^box:(.*)$/);
  const v = m[1].split(",").map(Number), blo = v.slice(0, 3), bhi = v.slice(3);
  const moved = face.side ? hi[k] - bhi[k] : blo[k] - lo[k];
  console.log(`dragged face ${"xyz"[k]}${face.side ? "+" : "-"} inwards by ${(moved / extent).toFixed(3)} of the extent`);
  assert.ok(moved > 0.1 * extent && moved < 0.4 * extent, `the face moved about a quarter inwards: ${sent.roi}`);
  for (let i = 0; i < 3; ++i) {
    if (i !== k || face.side) assert.ok(Math.abs(blo[i] - lo[i]) < 1e-5 * (hi[i] - lo[i] || 1), `lo ${i} kept: ${sent.roi}`);
    if (i !== k || !face.side) assert.ok(Math.abs(bhi[i] - hi[i]) < 1e-5 * (hi[i] - lo[i] || 1), `hi ${i} kept: ${sent.roi}`);
  }
  assert.deepEqual(await hook("camera"), cameraBefore, "the camera did not move");
  const s = await waitConverged(page, CONVERGE_MS);
  assert.ok(s.status.exact.focus_excluded > 0, "nodes outside the smaller box are context");
  await page.uncheck("#roi-drag");
  await page.click("#interest-clear");
  await waitConverged(page, CONVERGE_MS);
});
