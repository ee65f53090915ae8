#!/usr/bin/env python3
"""Time to the first image of `ugvr view MESH` (issue 24): starts the viewer on a mesh with a fresh store path, and
measures from the process's start

  - url_s: the URL printed (the server listens);
  - the progress messages a tab gets (stage, label, fraction, first time each stage/label is seen);
  - first_image_s: the first frame (a binary WebSocket message after hello);
  - first_image_texel_px: that frame's max_texel_error (status; screen pixels per texel of the cut's nodes);
  - preview_s: out of core, the first progress message saying a coarse preview is shown (octree/coarse_preview.h);
  - sketch_s: out of core, the first progress message saying the point sketch is shown (octree/point_sketch.h);
    first_image_shown and cut_shown: what the frame showed ("sketch", "preview", "store");
  - cut_s (with --cut-px P): the first frame whose cut has max_texel_error <= P px (cut_from_preview: while the
    coarse preview was shown, before the store), not counting the point sketch's frames (sketch_cut_s: the first
    such frame of the sketch); the run then goes on until that frame comes;
  - ready_s: the store shown (progress "ready"), if it comes within --wait seconds after the first image;
  - peak_rss_bytes: the viewer's VmHWM at the end.

The tab connects as soon as the URL is printed and says hello at 512x512. Uses bench/view_socket_check.py's
standard-library WebSocket client. Prints one JSON line.

Usage: first_image.py UGVR MESH STORE [--wait S] [--cut-px P] [-- VIEW_FLAGS...]
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from view_socket_check import WebSocket  # noqa: E402


def hwm(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ugvr")
    ap.add_argument("mesh")
    ap.add_argument("store")
    ap.add_argument("--wait", type=float, default=0, help="seconds to wait for the store after the first image")
    ap.add_argument("--timeout", type=float, default=900)
    ap.add_argument("--cut-px", type=float, default=0, help="also wait for a cut with texels of at most this size")
    argv = sys.argv[1:]
    flags = argv[argv.index("--") + 1:] if "--" in argv else []
    args = ap.parse_args(argv[:argv.index("--")] if "--" in argv else argv)
    for p in (args.store, args.store + ".lock"):
        if os.path.exists(p):
            os.remove(p)
    start = time.monotonic()
    log = open(args.store + ".log", "w")
    server = subprocess.Popen([args.ugvr, "view", args.mesh, "--store", args.store, "--port", "0"] + flags,
                              stdout=subprocess.PIPE, stderr=log, text=True)
    out = {"bench": "first_image", "mesh": os.path.basename(args.mesh), "flags": " ".join(flags)}
    seen = {}
    try:
        line = server.stdout.readline()
        out["url_s"] = round(time.monotonic() - start, 3)
        m = re.search(r"http://([^:/]+):(\d+)(/\S*)", line)
        if not m:
            raise RuntimeError("no URL in: " + line)
        ws = WebSocket(m.group(1), int(m.group(2)), "/ws")
        ws.sock.settimeout(args.timeout)
        ws.send_json({"type": "hello", "width": 512, "height": 512})
        first, ready, last_status = None, None, {}
        shown = "store"  # what the frames show: "sketch", "preview", or the store (or the exact engine's grid)

        def cut_done():
            return args.cut_px <= 0 or "cut_s" in out

        while True:
            text, data = ws.recv()
            now = round(time.monotonic() - start, 3)
            if not text:
                texel = last_status.get("max_texel_error")
                # A sketch's fine cut is not data at that resolution (octree/point_sketch.h): timed apart.
                if args.cut_px > 0 and texel is not None and texel <= args.cut_px and shown == "sketch":
                    out.setdefault("sketch_cut_s", now)
                elif args.cut_px > 0 and texel is not None and texel <= args.cut_px and "cut_s" not in out:
                    out["cut_s"] = now
                    out["cut_px"] = args.cut_px
                    out["cut_from_preview"] = ready is None and "preview_s" in out
                    out["cut_shown"] = "store" if ready is not None else shown
                if first is None:
                    first = now
                    out["first_image_s"] = first
                    out["first_image_engine"] = last_status.get("engine")
                    out["first_image_texel_px"] = texel
                    out["first_image_shown"] = shown
                    # The store was shown first (the out-of-core path without a preview).
                    if (args.wait <= 0 or ready is not None) and cut_done():
                        break
                if first is not None and now - first > args.wait and cut_done():
                    break
                continue
            msg = json.loads(data)
            if msg["type"] == "status":
                last_status = msg
            elif msg["type"] == "progress":
                key = msg["stage"] + ("/" + msg["label"] if msg["label"] else "")
                seen.setdefault(key, now)
                # The page's line while the preview is shown; the out-of-core notice only announces one.
                if "coarse preview (levels" in msg.get("message", ""):
                    out.setdefault("preview_s", now)
                    shown = "preview"
                # The point sketch (octree/point_sketch.h), shown before the preview.
                if "sketch from the mesh's points" in msg.get("message", ""):
                    out.setdefault("sketch_s", now)
                    shown = "sketch"
                if msg["stage"] == "failed":
                    raise RuntimeError(msg["message"])
                if msg["stage"] == "ready":
                    ready = now
                    out["ready_s"] = ready
                    if first is not None and cut_done():
                        break
            if first is not None and now - first > args.wait and cut_done():
                break
    except BaseException as e:  # what was measured so far is still worth printing (Ctrl-C included)
        out["error"] = repr(e)
    finally:
        out["progress_first_seen_s"] = seen
        out["peak_rss_bytes"] = hwm(server.pid)
        server.terminate()
        server.wait(timeout=120)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
