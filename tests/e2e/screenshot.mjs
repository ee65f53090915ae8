// Saves a PNG of the `ugvr view` page for the docs: starts the viewer on a store, opens it in headless Chromium at
// 1000x700, waits for the full-quality frame and takes a screenshot of the whole page.
//   node tests/e2e/screenshot.mjs UGVR_BINARY STORE.ugvr OUT.png [--preset NAME] [--turn DX,DY]
// (npm ci --prefix tests/e2e first; --turn drags the view by DX, DY pixels before the shot.)
import { launchBrowser, startViewer, stopViewer, waitConverged } from "./lib.mjs";

const [ugvr, store, out, ...rest] = process.argv.slice(2);
if (!ugvr || !store || !out) {
  console.error("usage: node screenshot.mjs UGVR_BINARY STORE.ugvr OUT.png [--preset NAME] [--turn DX,DY]");
  process.exit(2);
}
const opt = (name) => { const i = rest.indexOf(name); return i >= 0 ? rest[i + 1] : undefined; };

const viewer = await startViewer(ugvr, store);
const browser = await launchBrowser();
try {
  const page = await browser.newPage({ viewport: { width: 1000, height: 700 } });
  await page.goto(viewer.url);
  await waitConverged(page, 120_000);
  if (opt("--preset")) await page.selectOption("#preset", opt("--preset"));
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
