// Helpers shared by viewer.test.mjs and screenshot.mjs: start `ugvr view`, launch headless Chromium, wait for the
// page's state through its test hook (window.ugvrViewer in web/app.js).
import { spawn } from "node:child_process";
import assert from "node:assert/strict";
import { chromium } from "playwright-core";

export const chromiumPath = process.env.UGVR_CHROMIUM || "/usr/bin/chromium";

// Starts `ugvr view STORE --port 0` and resolves with { url, process, log() } once it prints its URL.
export function startViewer(ugvr, store, extraArgs = [], timeoutMs = 60_000) {
  return new Promise((resolve, reject) => {
    const child = spawn(ugvr, ["view", store, "--port", "0", ...extraArgs], { stdio: ["ignore", "pipe", "pipe"] });
    // Never left behind: killed when node exits, also on SIGINT / SIGTERM (a timeout), which then exit.
    process.once("exit", () => child.kill("SIGKILL"));
    for (const sig of ["SIGINT", "SIGTERM"]) process.once(sig, () => process.exit(1));
    let out = "", err = "";
    const log = () => `ugvr view stdout:\n${out}\nugvr view stderr:\n${err}`;
    const timer = setTimeout(() => {
      child.kill("SIGKILL");
      reject(new Error(`ugvr view printed no URL within ${timeoutMs} ms\n${log()}`));
    }, timeoutMs);
    child.stderr.on("data", (d) => { err += d; });
    child.stdout.on("data", (d) => {
      out += d;
      const m = /ugvr view: serving (\S+)/.exec(out);
      if (m) {
        clearTimeout(timer);
        resolve({ url: m[1], process: child, log });
      }
    });
    child.on("error", (e) => { clearTimeout(timer); reject(e); });
    child.on("exit", (code, signal) => {
      clearTimeout(timer);
      reject(new Error(`ugvr view exited (${code ?? signal}) before printing its URL\n${log()}`));
    });
  });
}

// Stops a viewer started by startViewer: SIGTERM, then SIGKILL if it has not exited within a few seconds.
export async function stopViewer(viewer) {
  const child = viewer?.process;
  if (!child || child.exitCode !== null || child.signalCode !== null) return;
  const exited = new Promise((resolve) => child.once("exit", resolve));
  child.kill("SIGTERM");
  const timer = setTimeout(() => child.kill("SIGKILL"), 10_000);
  await exited;
  clearTimeout(timer);
}

export function launchBrowser() {
  return chromium.launch({
    executablePath: chromiumPath,
    headless: true,
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-dev-shm-usage",
           // Frames keep coming to a tab in the background (the two-tab test has one).
           "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
           "--disable-backgrounding-occluded-windows"],
  });
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Polls fn (async, returns a truthy value when done) every intervalMs until it is truthy or timeoutMs passes.
// A new context of `browser` (newContext's options) with one page opened at `url`; the page's errors go to stderr.
export async function openPage(browser, url, contextOptions) {
  const context = await browser.newContext(contextOptions);
  const page = await context.newPage();
  page.on("pageerror", (e) => console.error(`page error: ${e.message}`));
  await page.goto(url);
  return { context, page };
}

export async function waitFor(what, fn, timeoutMs, intervalMs = 50) {
  const start = Date.now();
  let last;
  for (;;) {
    last = await fn();
    if (last) return last;
    if (Date.now() - start > timeoutMs) throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
    await sleep(intervalMs);
  }
}

export const viewerState = (page) =>
  page.evaluate(() => {
    const v = window.ugvrViewer;
    return v && { camera: v.camera, status: v.status, frames: v.frames, sent: v.sent, error: v.error };
  });

// Waits until the canvas shows a converged (full quality) frame of every message the page has sent; returns the
// page's state then.
export function waitConverged(page, timeoutMs) {
  return waitFor("a full-quality frame reflecting every message sent", async () => {
    const s = await viewerState(page);
    return s && s.status && s.status.converged && s.status.request >= s.sent ? s : null;
  }, timeoutMs);
}

// The canvas pixels, every `step`-th pixel in both directions, as a flat RGB array.
export const canvasPixels = (p, step = 4) =>
  p.evaluate((step) => {
    const c = document.getElementById("canvas");
    const data = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
    const out = [];
    for (let y = 0; y < c.height; y += step)
      for (let x = 0; x < c.width; x += step) {
        const i = (y * c.width + x) * 4;
        out.push(data[i], data[i + 1], data[i + 2]);
      }
    return out;
  }, step);

// Fraction of sampled pixels differing by more than 2 levels in some channel. The images compared are converged
// frames (PNG, lossless), so any difference is real.
export function changedFraction(a, b) {
  assert.equal(a.length, b.length, "image size changed");
  let changed = 0;
  for (let i = 0; i < a.length; i += 3)
    if (Math.abs(a[i] - b[i]) > 2 || Math.abs(a[i + 1] - b[i + 1]) > 2 || Math.abs(a[i + 2] - b[i + 2]) > 2) ++changed;
  return changed / (a.length / 3);
}

// Fraction of sampled pixels that differ from the background (the top-left pixel, outside the volume).
export function foregroundFraction(px) {
  let fg = 0;
  for (let i = 0; i < px.length; i += 3)
    if (Math.abs(px[i] - px[0]) > 8 || Math.abs(px[i + 1] - px[1]) > 8 || Math.abs(px[i + 2] - px[2]) > 8) ++fg;
  return fg / (px.length / 3);
}

// Drags across the middle of the canvas by (dx, dy) in 10 steps; button "left" | "right" | "middle", shift held or not.
export async function drag(p, dx, dy, { button = "left", shift = false } = {}) {
  const box = await p.locator("#canvas").boundingBox();
  const x = box.x + box.width / 2, y = box.y + box.height / 2;
  await p.mouse.move(x, y);
  if (shift) await p.keyboard.down("Shift");
  await p.mouse.down({ button });
  for (let i = 1; i <= 10; ++i) await p.mouse.move(x + (dx * i) / 10, y + (dy * i) / 10);
  await p.mouse.up({ button });
  if (shift) await p.keyboard.up("Shift");
}

export const cameraMoved = (a, b) => a.position.some((v, i) => Math.abs(v - b.position[i]) > 1e-6 * (1 + Math.abs(v)));
