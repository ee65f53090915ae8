#!/usr/bin/env python3
"""Puts PNG images side by side, left to right, into one PNG (the docs' before/after pictures).

Usage: bench/side_by_side.py OUT.png IN1.png IN2.png ... [--crop X,Y,W,H] [--gap N]
--crop takes the same rectangle of every input (pixels, top left X,Y); --gap puts N white columns between them.
Standard library only (zlib): the machines this runs on have neither numpy, Pillow nor ImageMagick. Reads 8-bit
greyscale, RGB and RGBA PNGs without interlacing (what `ugvr render` writes); writes 8-bit RGB.
"""
import struct
import sys
import zlib


def read_png(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit(f"{path}: not a PNG")
    pos, idat = 8, b""
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or colour not in (0, 2, 6) or interlace:
                sys.exit(f"{path}: only 8-bit grey/RGB/RGBA, not interlaced")
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    bpp = {0: 1, 2: 3, 6: 4}[colour]
    raw, stride = zlib.decompress(idat), w * bpp
    rows, prev, at = [], bytearray(stride), 0
    for _ in range(h):
        kind, line = raw[at], bytearray(raw[at + 1:at + 1 + stride])
        at += 1 + stride
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if kind == 1:
                line[x] = (line[x] + a) & 255
            elif kind == 2:
                line[x] = (line[x] + b) & 255
            elif kind == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        prev = line
        rgb = bytearray()
        for x in range(w):
            px = line[x * bpp:x * bpp + bpp]
            rgb += bytes(px[0:1] * 3) if bpp == 1 else bytes(px[0:3])
        rows.append(rgb)
    return w, h, rows


def write_png(path, w, h, rows):
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    raw = b"".join(b"\0" + bytes(r) for r in rows)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def main(argv):
    crop, gap, files = None, 0, []
    it = iter(argv[1:])
    for a in it:
        if a == "--crop":
            crop = [int(v) for v in next(it).split(",")]
        elif a == "--gap":
            gap = int(next(it))
        else:
            files.append(a)
    if len(files) < 2:
        sys.exit(__doc__)
    out, images = files[0], [read_png(f) for f in files[1:]]
    if crop:
        x0, y0, cw, ch = crop
        images = [(cw, ch, [r[3 * x0:3 * (x0 + cw)] for r in rows[y0:y0 + ch]]) for _, _, rows in images]
    h = max(i[1] for i in images)
    w = sum(i[0] for i in images) + gap * (len(images) - 1)
    white = bytes([255] * 3 * gap)
    rows = []
    for y in range(h):
        parts = [(rows_[y] if y < ih else bytes(3 * iw)) for iw, ih, rows_ in images]
        rows.append(white.join(parts))
    write_png(out, w, h, rows)


if __name__ == "__main__":
    main(sys.argv)
