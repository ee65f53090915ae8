// Saves a PNG of the `ugvr view` page for the docs: starts the viewer on a store, opens it in headless Chromium at
// 1000x700, waits for the full-quality frame and takes a screenshot of the whole page.
//   node tests/e2e/screenshot.mjs UGVR_BINARY STORE.ugvr|MESH|--demo OUT.png [--preset NAME] [--turn DX,DY]
//        [--engine exact|lod] [-- VIEW_ARGS...]
// (npm ci --prefix tests/e2e first; --turn drags the view by DX, DY pixels before the shot; --engine picks the engine
// in the page's engine picker (exact: a grid, not a store); arguments after -- go to `ugvr view`. A grid whose store
// is still being built is shot once the store is shown.)
import { launchBrowser, startViewer, stopViewer, waitConverged } from "./lib.mjs";

const [ugvr, store, out, ...rest] = process.argv.slice(2);
if (!ugvr || !store || !out) {
  console.error("usage: node screenshot.mjs UGVR_BINARY STORE.ugvr OUT.png [--preset NAME] [--turn DX,DY]");
  process.exit(2);
}
const dashes = rest.indexOf("--");
const viewArgs = dashes >= 0 ? rest.slice(dashes + 1) : [];
const opt = (name) => { const i = rest.indexOf(name); return i >= 0 && (dashes < 0 || i < dashes) ? rest[i + 1] : undefined; };

const viewer = await startViewer(ugvr, store, viewArgs);
const browser = await launchBrowser();
try {
  const page = await browser.newPage({ viewport: { width: 1000, height: 700 } });
  await page.goto(viewer.url);
  // A store built in the background: wait until the page shows it (the level-of-detail engine).
  await page.waitForFunction(() => window.ugvrViewer.status && window.ugvrViewer.status.engine === "lod", null,
                             { timeout: 600_000, polling: 250 });
  await waitConverged(page, 120_000);
  if (opt("--preset")) await page.selectOption("#preset", opt("--preset"));
  if (opt("--engine")) {
    await page.selectOption("#engine", opt("--engine"));
    await page.waitForFunction((e) => window.ugvrViewer.status && window.ugvrViewer.status.engine === e, opt("--engine"),
                               { timeout: 120_000, polling: 250 });
  }
  if (opt("--turn")) {
    const [dx, dy] = opt("--turn").split(",").map(Number);
    const box = await page.locator("#canvas").boundingBox();
    const x = box.x + box.width / 2, y = box.y + box.height / 2;
    await page.mouse.move(x, y);
    await page.mouse.down();
    for (let i = 1; i <= 10; ++i) await page.mouse.move(x + (dx * i) / 10, y + (dy * i) / 10);
    await page.mouse.up();
  }
  await waitConverged(page, 120_000);
  await page.screenshot({ path: out });
  console.log(`wrote ${out}`);
} finally {
  await browser.close();
  await stopViewer(viewer);
}
