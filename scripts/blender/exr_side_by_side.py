"""Puts OpenEXR images side by side in one 8-bit sRGB PNG; numpy only (a small reader of
scanline EXRs, uncompressed, ZIPS or ZIP, half or float: what vdbscatter and Blender write).
Used for docs/handoff_blender*.png.

    python3 scripts/blender/exr_side_by_side.py OUT.png A.exr B.exr [C.exr ...]
        [--exposure EV] [--zoom K] [--diff]
    (or: blender -b -P scripts/blender/exr_side_by_side.py -- OUT.png A.exr ...)

--diff appends |A - B| * 4 (of the first two images) as a last panel."""
import argparse
import struct
import sys
import zlib

import numpy as np


def load(path):
    """(height, width, 3) float array of R, G, B of a scanline OpenEXR file."""
    with open(path, "rb") as f:
        blob = f.read()
    assert struct.unpack_from("<I", blob, 0)[0] == 20000630, path
    pos, attrs = 8, {}
    while blob[pos] != 0:
        end = blob.index(b"\0", pos)
        tend = blob.index(b"\0", end + 1)
        (size,) = struct.unpack_from("<i", blob, tend + 1)
        attrs[blob[pos:end].decode()] = blob[tend + 5:tend + 5 + size]
        pos = tend + 5 + size
    pos += 1
    chans, raw = [], attrs["channels"]
    i = 0
    while raw[i] != 0:
        end = raw.index(b"\0", i)
        chans.append((raw[i:end].decode(), struct.unpack_from("<i", raw, end + 1)[0]))
        i = end + 1 + 16
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    comp = attrs["compression"][0]
    lines = {0: 1, 2: 1, 3: 16}[comp]
    nblocks = (h + lines - 1) // lines
    offsets = struct.unpack_from("<%dQ" % nblocks, blob, pos)
    out = {name: np.zeros((h, w), np.float32) for name, _ in chans}
    for off in offsets:
        y, size = struct.unpack_from("<ii", blob, off)
        data = blob[off + 8:off + 8 + size]
        n = min(lines, y1 - y + 1)
        expect = n * w * sum(2 if t == 1 else 4 for _, t in chans)
        if comp and size < expect:
            d = np.frombuffer(zlib.decompress(data), np.uint8).astype(np.int64)
            d = (np.cumsum(d - 128) + 128) & 0xFF
            d[0] = np.frombuffer(zlib.decompress(data), np.uint8)[0]
            half = (len(d) + 1) // 2
            t = np.empty(len(d), np.uint8)
            t[0::2], t[1::2] = d[:half], d[half:]
            data = t.tobytes()
        p = 0
        for row in range(n):
            for name, kind in chans:
                dt, nb = (np.float16, 2) if kind == 1 else (np.float32, 4)
                out[name][y - y0 + row] = np.frombuffer(data, dt, w, p).astype(np.float32)
                p += w * nb
    return np.stack([out["R"], out["G"], out["B"]], axis=2)


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def write_png(path, rgb8):
    h, w, _ = rgb8.shape
    raw = b"".join(b"\0" + rgb8[y].tobytes() for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("images", nargs="+")
    p.add_argument("--exposure", type=float, default=0.0)
    p.add_argument("--zoom", type=int, default=1)
    p.add_argument("--diff", action="store_true")
    a = p.parse_args(argv)
    panels = [load(i) for i in a.images]
    if a.diff:
        panels.append(np.abs(panels[0] - panels[1]) * 4.0)
    h = panels[0].shape[0]
    gap = np.ones((h, 2, 3), dtype=np.float32)
    row = []
    for i, im in enumerate(panels):
        row += ([gap] if i else []) + [im * 2.0 ** a.exposure]
    pic = np.concatenate(row, axis=1)
    pic = np.repeat(np.repeat(pic, a.zoom, axis=0), a.zoom, axis=1)
    write_png(a.out, (srgb(pic) * 255 + 0.5).astype(np.uint8))
    print(f"exr_side_by_side: wrote {a.out} ({pic.shape[1]}x{pic.shape[0]})")


main()
