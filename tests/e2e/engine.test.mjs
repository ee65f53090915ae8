// End-to-end test of the page's engine picker (web/: #engine): a viewer started from a grid shows it with the exact
// engine while its store is built, then with the level-of-detail engine, and the page switches between the two.
// Run by run.sh, which sets UGVR (the binary) and UGVR_MESH (a small generated mesh); the store is built next to it.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import { launchBrowser, startViewer, stopViewer, viewerState, waitConverged, waitFor } from "./lib.mjs";

const UGVR = process.env.UGVR, MESH = process.env.UGVR_MESH;
if (!UGVR || !MESH) throw new Error("set UGVR (the ugvr binary) and UGVR_MESH (a grid file); run.sh does");

const CONVERGE_MS = 60_000;
const BUILD_MS = 60_000;  // the store of the 20,000-cell mesh, built while the exact engine shows it
const VIEWPORT = { width: 720, height: 480 };  // small: the exact engine draws every pixel on the CPU here

let viewer, browser, page;

const hook = (expr) => page.evaluate(`window.ugvrViewer.${expr}`);
const statusText = () => page.locator("#status").textContent();

before(async () => {
  const store = MESH.replace(/\.[^.]+$/, "") + "-engine.ugvr";
  viewer = await startViewer(UGVR, MESH, ["--store", store, "--max-depth", "4", "--fields", "pressure"]);
  browser = await launchBrowser();
  page = await (await browser.newContext({ viewport: VIEWPORT })).newPage();
  page.on("pageerror", (e) => console.error(`page error: ${e.message}`));
  await page.goto(viewer.url);
});

after(async () => {
  await browser?.close();
  await stopViewer(viewer);
});

test("the engine picker offers the exact engine while the store is built, then both", async () => {
  await waitFor("the first scene", () => hook("scene"), 10_000);
  // The scene and the picker read at once: the store's scene may come at any moment.
  const { first, e } = await page.evaluate(() => ({ first: window.ugvrViewer.scene, e: window.ugvrViewer.engine }));
  console.log(`first scene seen: engine ${first.engine}, engines ${first.engines.join(", ")}`);
  if (first.engine === "exact") {
    // The store is being built: the exact engine is the only one, and the picker says so.
    assert.deepEqual(first.engines, ["exact"]);
    assert.equal(e.picked, "exact");
    assert.deepEqual(e.options, ["exact"]);
    assert.equal(e.disabled, true, "one engine: nothing to pick");
    assert.match(e.renderer, /^exact engine \((CPU|GPU: .+)\)$/);
  }
  await waitFor("the store's scene", async () => (await hook("scene")).engine === "lod", BUILD_MS, 250);
  const scene = await hook("scene");
  assert.deepEqual(scene.engines, ["exact", "lod"], "the grid is kept: both engines");
  const s = await waitConverged(page, CONVERGE_MS);
  assert.equal(s.status.engine, "lod");
  const both = await hook("engine");
  assert.deepEqual(both.options, ["exact", "lod"]);
  assert.equal(both.disabled, false);
  assert.equal(both.picked, "lod");
  assert.equal(both.renderer, scene.renderers.lod);
  assert.match(await statusText(), /^lod /);
});

// The build of this small mesh may be over before the page's first scene: what the picker shows while a store is
// built is checked here with such a scene delivered to the page's own handler (the server's side of it is
// tests/test_view_server.cpp's), then the real one again.
test("with one engine the picker shows it and its renderer, disabled", async () => {
  await waitConverged(page, CONVERGE_MS);
  const deliver = (m) => page.evaluate((text) => ws.onmessage({ data: text }), JSON.stringify(m));
  const scene = await hook("scene");
  await deliver({ ...scene, engine: "exact", renderer: "exact engine (CPU)", engines: ["exact"],
                  renderers: { exact: "exact engine (CPU)" } });
  let e = await hook("engine");
  assert.deepEqual(e, { picked: "exact", options: ["exact"], disabled: true, renderer: "exact engine (CPU)" });
  await deliver(scene);
  e = await hook("engine");
  assert.deepEqual(e, { picked: "lod", options: ["exact", "lod"], disabled: false, renderer: scene.renderers.lod });
  assert.equal((await waitConverged(page, CONVERGE_MS)).status.engine, "lod");
});

test("picking the exact engine draws the view with it; picking the store again goes back", async () => {
  const before = await waitConverged(page, CONVERGE_MS);
  await page.selectOption("#engine", "exact");
  let s = await waitConverged(page, CONVERGE_MS);
  assert.ok(s.frames > before.frames, "new frames arrived");
  assert.equal(s.status.engine, "exact", "the frame on the canvas is the exact engine's");
  const text = await statusText();
  assert.match(text, /^exact .*full quality$/);
  assert.doesNotMatch(text, /texel error|MiB/, "no level-of-detail figures for the exact engine");
  const e = await hook("engine");
  assert.equal(e.picked, "exact");
  assert.equal(e.renderer, (await hook("scene")).renderers.exact);
  assert.match(e.renderer, /^exact engine/);
  assert.deepEqual((await hook("log")).filter((m) => m.type === "engine").pop(), { type: "engine", engine: "exact" });
  assert.equal(s.error, "");

  await page.selectOption("#engine", "lod");
  s = await waitConverged(page, CONVERGE_MS);
  assert.equal(s.status.engine, "lod");
  assert.match(await statusText(), /^lod /);
  assert.equal((await hook("engine")).renderer, (await hook("scene")).renderers.lod);
  assert.equal(s.error, "");
});
