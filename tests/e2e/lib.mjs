// Helpers shared by viewer.test.mjs and screenshot.mjs: start `ugvr view`, launch headless Chromium, wait for the
// page's state through its test hook (window.ugvrViewer in web/app.js).
import { spawn } from "node:child_process";
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
