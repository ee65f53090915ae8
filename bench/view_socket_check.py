#!/usr/bin/env python3
"""The browser viewer's render path without a browser: starts `ugvr view`, speaks its WebSocket protocol
(src/ugvr/view/view_protocol.h) from the standard library alone, and measures what a tab would get.

Made for GPU machines, which have no browser (bench/run_gpu.sh): it checks that the viewer's frames come from the
GPU (the scene's `renderer`), and times

  - the first frame and the first converged frame after `hello`,
  - input-to-new-frame latency while the camera orbits (a camera message is sent, then the client waits for the
    first frame whose status says it reflects that message; the next message goes out then),
  - a full-quality frame on request (saved as PNG).

Usage: view_socket_check.py UGVR STORE_OR_MESH OUT_DIR [--size WxH] [--moves N] [--fps F]
Prints one JSON line (also written to OUT_DIR/view_check.json).
"""
import argparse
import base64
import json
import math
import os
import re
import socket
import statistics
import struct
import subprocess
import sys
import time


class WebSocket:
    """A minimal RFC 6455 client: masked text frames out; text, binary and continuation frames in."""

    def __init__(self, host, port, path):
        self.sock = socket.create_connection((host, port), timeout=60)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise RuntimeError("connection closed during the WebSocket handshake")
            head += chunk
        status, _, self.buf = head.partition(b"\r\n\r\n")
        if b" 101 " not in status.split(b"\r\n")[0]:
            raise RuntimeError("handshake refused: " + status.split(b"\r\n")[0].decode(errors="replace"))

    def _read(self, n):
        while len(self.buf) < n:
            chunk = self.sock.recv(1 << 20)
            if not chunk:
                raise RuntimeError("connection closed")
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out

    def send_json(self, obj):
        data = json.dumps(obj).encode()
        head = bytes([0x81])
        n = len(data)
        if n < 126:
            head += bytes([0x80 | n])
        elif n < 65536:
            head += bytes([0x80 | 126]) + struct.pack(">H", n)
        else:
            head += bytes([0x80 | 127]) + struct.pack(">Q", n)
        mask = os.urandom(4)
        self.sock.sendall(head + mask + bytes(b ^ mask[i & 3] for i, b in enumerate(data)))

    def recv(self):
        """One whole message: (is_text, payload)."""
        payload, opcode = b"", None
        while True:
            b0, b1 = self._read(2)
            n = b1 & 0x7F
            if n == 126:
                n = struct.unpack(">H", self._read(2))[0]
            elif n == 127:
                n = struct.unpack(">Q", self._read(8))[0]
            data = self._read(n)
            op = b0 & 0x0F
            if op == 8:
                raise RuntimeError("server closed the socket")
            if op == 9:  # ping: the server's keep-alive (Beast closes a socket idle 300 s without a pong)
                mask = os.urandom(4)
                self.sock.sendall(bytes([0x8A, 0x80 | len(data)]) + mask +
                                  bytes(b ^ mask[i & 3] for i, b in enumerate(data)))
                continue
            if op == 10:
                continue
            if op != 0:
                opcode = op
            payload += data
            if b0 & 0x80:
                return opcode == 1, payload


def next_frame(ws):
    """Skips to the next status + binary frame pair; returns (status dict, image bytes, other messages)."""
    others = []
    while True:
        text, data = ws.recv()
        if not text:
            continue
        msg = json.loads(data)
        if msg["type"] == "status":
            is_text, image = ws.recv()
            if is_text:
                raise RuntimeError("a status message was not followed by a binary frame")
            return msg, image, others
        if msg["type"] == "error":
            raise RuntimeError("server rejected a message: " + msg["message"])
        others.append(msg)


def orbit(camera, degrees):
    """The camera turned about the focal point's vertical (view_up) axis."""
    p, f, up = camera["position"], camera["focal_point"], camera["view_up"]
    d = [p[i] - f[i] for i in range(3)]
    n = math.sqrt(sum(u * u for u in up))
    k = [u / n for u in up]
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)
    kxd = [k[1] * d[2] - k[2] * d[1], k[2] * d[0] - k[0] * d[2], k[0] * d[1] - k[1] * d[0]]
    kd = sum(k[i] * d[i] for i in range(3))
    r = [d[i] * c + kxd[i] * s + k[i] * kd * (1 - c) for i in range(3)]
    out = dict(camera)
    out["position"] = [f[i] + r[i] for i in range(3)]
    return out


def peak_rss(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ugvr")
    ap.add_argument("input")
    ap.add_argument("out")
    ap.add_argument("--size", default="1024x768")
    ap.add_argument("--moves", type=int, default=120)
    ap.add_argument("--fps", type=float, default=30)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    os.makedirs(args.out, exist_ok=True)

    started = time.perf_counter()
    server = subprocess.Popen([args.ugvr, "view", args.input, "--port", "0", "--fps", str(args.fps)],
                              stdout=subprocess.PIPE, stderr=open(os.path.join(args.out, "view.log"), "w"), text=True)
    try:
        line = server.stdout.readline()
        m = re.search(r"http://([^/:]+):(\d+)/", line)
        if not m:
            raise RuntimeError("ugvr view printed no URL: " + line.strip())
        url_seconds = time.perf_counter() - started
        ws = WebSocket(m.group(1), int(m.group(2)), "/ws")
        t0 = time.perf_counter()
        ws.send_json({"type": "hello", "width": w, "height": h})
        sent = 1
        status, image, others = next_frame(ws)
        first_frame = time.perf_counter() - t0
        scene = next(o for o in others if o["type"] == "scene")
        while not status["converged"]:
            status, image, _ = next_frame(ws)
        first_converged = time.perf_counter() - t0

        # Orbit: one camera message, then wait for the frame that reflects it.
        ws.send_json({"type": "settings", "fps": args.fps})
        sent += 1
        camera = scene["camera"]
        latencies, frame_seconds, scales = [], [], []
        for i in range(args.moves):
            camera = orbit(camera, 3.0)
            t = time.perf_counter()
            ws.send_json(dict(camera, type="camera"))
            sent += 1
            while True:
                status, image, _ = next_frame(ws)
                if status["request"] >= sent:
                    break
            latencies.append(time.perf_counter() - t)
            frame_seconds.append(status["frame_seconds"])
            scales.append(status["scale"])

        # At rest: a full-quality frame on request.
        t = time.perf_counter()
        ws.send_json({"type": "settings", "full_quality": True})
        sent += 1
        while True:
            status, image, _ = next_frame(ws)
            if status["request"] >= sent and status["converged"]:
                break
        full_quality = time.perf_counter() - t
        png = os.path.join(args.out, "view_full_quality." + status["format"])
        with open(png, "wb") as f:
            f.write(image)

        lat = sorted(latencies)
        result = {
            "bench": "view_socket", "input": os.path.basename(args.input.rstrip("/")), "size": [w, h],
            "fps_target": args.fps, "renderer": scene.get("renderer"), "engine": scene.get("engine"),
            "first_frame_seconds": first_frame, "first_converged_seconds": first_converged,
            "moves": args.moves, "latency_median_seconds": statistics.median(lat),
            "latency_p95_seconds": lat[int(0.95 * (len(lat) - 1))], "latency_max_seconds": lat[-1],
            "frame_seconds_median": statistics.median(frame_seconds), "mean_scale_moving": statistics.fmean(scales),
            "full_quality_seconds": full_quality, "full_quality_frame_seconds": status["frame_seconds"],
            "atlas_budget": status.get("atlas_budget"), "png": os.path.basename(png),
            # Since the command started (the first frame above counts from the page's hello), and the server's peak
            # resident set so far (Linux: VmHWM of its /proc status).
            "url_seconds": url_seconds, "first_frame_since_start_seconds": url_seconds + first_frame,
            "server_peak_rss_bytes": peak_rss(server.pid),
        }
        line = json.dumps(result, separators=(",", ":"))
        print(line)
        with open(os.path.join(args.out, "view_check.json"), "w") as f:
            f.write(line + "\n")
    finally:
        server.terminate()
        try:
            server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            server.kill()


if __name__ == "__main__":
    sys.exit(main())
