#!/usr/bin/env python3
"""`mpirun -np N ugvr view INPUT` frame times (docs/mpi.md, "The viewer on a cluster"), without a browser.

For each rank count (rounds alternate the counts, so that a change of load hits each alike): starts the job, opens one
tab (the WebSocket client of view_socket_check.py) at SIZE x SIZE, then
  - at rest: sets fps 0 (every frame full scale) and orbits the camera FRAMES times by 10 degrees, waiting for each
    frame; records the status's frame_seconds (rank 0's whole frame: the broadcast, every rank's render, IceT, the
    magnification) and the round trip (camera message sent to image received, encoding and the socket included);
  - moving: sets fps FPS and orbits FRAMES times again; records each frame's scale (the controller's choice from the
    slowest rank's time) and frame_seconds;
then SIGTERMs rank 0 and checks that the job ends with status 0. Prints one JSON line per run.

Usage: mpi_view_frames.py UGVR "INPUT..." [--ranks 1,2,4] [--rounds 2] [--size 512] [--frames 7] [--fps 5]
       [--threads 1] [--extra "view flags"]
"""
import argparse
import json
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from view_socket_check import WebSocket, next_frame, orbit  # noqa: E402


def start(ugvr, inputs, ranks, size, threads, extra, log):
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    cmd = (["mpirun", "--oversubscribe", "-np", str(ranks), ugvr, "--quiet", "view"] + inputs.split() +
           ["--port", "0", "--size", str(size), "--threads", str(threads)] + extra.split())
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=log, text=True, env=env)
    line = proc.stdout.readline()
    m = re.search(r"serving http://127\.0\.0\.1:(\d+)/", line)
    if not m:
        raise RuntimeError("no URL from the viewer: " + line)
    for _ in range(200):
        log.flush()
        with open(log.name) as f:
            p = re.search(r"rank 0 is pid (\d+)", f.read())
        if p:
            return proc, int(m.group(1)), int(p.group(1))
        time.sleep(0.05)
    raise RuntimeError("no rank 0 pid in the viewer's log")


def frame_after(ws, request):
    while True:
        status, _, _ = next_frame(ws)
        if status["request"] >= request:
            return status


def run(args, ranks):
    with tempfile.NamedTemporaryFile("w+", suffix=".log") as log:
        proc, port, pid = start(args.ugvr, args.inputs, ranks, args.size, args.threads, args.extra, log)
        ws = WebSocket("127.0.0.1", port, "/ws")
        ws.send_json({"type": "hello", "width": args.size, "height": args.size})
        sent = 1
        scene = None
        while scene is None:
            text, data = ws.recv()
            if text and json.loads(data)["type"] == "scene":
                scene = json.loads(data)
        first = frame_after(ws, sent)
        camera = dict(scene["camera"])
        ws.send_json({"type": "settings", "fps": 0})
        sent += 1
        frame_after(ws, sent)
        rest, trips = [], []
        for _ in range(args.frames):
            camera = orbit(camera, 10)
            t0 = time.perf_counter()
            ws.send_json(dict(camera, type="camera"))
            sent += 1
            s = frame_after(ws, sent)
            trips.append(time.perf_counter() - t0)
            rest.append(s["frame_seconds"])
        ws.send_json({"type": "settings", "fps": args.fps})
        sent += 1
        moving = []
        for _ in range(args.frames):
            camera = orbit(camera, 10)
            ws.send_json(dict(camera, type="camera"))
            sent += 1
            s = frame_after(ws, sent)
            moving.append((s["scale"], s["frame_seconds"]))
        os.kill(pid, signal.SIGTERM)
        code = proc.wait(timeout=120)
        with open(log.name) as f:
            tail = f.read()[-2000:]
    return {"ranks": ranks, "size": args.size, "threads_per_rank": args.threads, "renderer": scene["renderer"],
            "first_frame_seconds": first["frame_seconds"],
            "rest_frame_seconds_median": statistics.median(rest), "rest_frame_seconds": rest,
            "rest_round_trip_median": statistics.median(trips),
            "moving_fps_target": args.fps, "moving_scale_median": statistics.median(m[0] for m in moving),
            "moving_frame_seconds_median": statistics.median(m[1] for m in moving),
            "exit_status": code, "log_tail": tail if code != 0 else "",
            "load": os.getloadavg()[0]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ugvr")
    ap.add_argument("inputs")
    ap.add_argument("--ranks", default="1,2,4")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--frames", type=int, default=7)
    ap.add_argument("--fps", type=float, default=5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--extra", default="")
    args = ap.parse_args()
    for _ in range(args.rounds):
        for ranks in [int(r) for r in args.ranks.split(",")]:
            print(json.dumps(run(args, ranks)), flush=True)


if __name__ == "__main__":
    main()
