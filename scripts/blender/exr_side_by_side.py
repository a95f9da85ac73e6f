"""Puts OpenEXR images side by side in one 8-bit sRGB PNG (Blender reads the EXRs; no other
dependency). Used for docs/handoff_blender.png and bench/blender_handoff.png.

    blender -b -P scripts/blender/exr_side_by_side.py -- OUT.png A.exr B.exr [C.exr ...]
        [--exposure EV] [--zoom K] [--diff]

--diff appends |A - B| * 4 (of the first two images) as a last panel."""
import argparse
import struct
import sys
import zlib

import bpy
import numpy as np


def load(path):
    img = bpy.data.images.load(path)
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    return px.reshape(h, w, 4)[::-1, :, :3]  # Blender stores rows bottom-up


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
    argv = sys.argv[sys.argv.index("--") + 1:]
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
