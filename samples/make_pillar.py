#!/usr/bin/python3
"""Writes samples/pillar.obj: a low-poly column (an octagonal shaft between a square base
and a square capital, 52 triangles) for the occluder sample scene. Its own frame: the
shaft runs along Y from -1 to 1, radius 0.25; base and capital are 0.7 wide, 0.15 high.
Exercises the OBJ forms the reader accepts: v//vn on the shaft, plain v on the boxes,
polygons (quads, octagon caps) that the reader fans into triangles."""
import math
import os

SIDES = 8
RADIUS = 0.25
HALF = 0.35   # half width of base and capital
SLAB = 0.15   # their height


def main():
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pillar.obj")
    lines = ["# pillar.obj: written by samples/make_pillar.py (do not edit)", "o pillar"]
    v = []

    def vertex(x, y, z):
        v.append((x, y, z))
        lines.append(f"v {x:.6f} {y:.6f} {z:.6f}")
        return len(v)

    # octagonal shaft from the top of the base to the bottom of the capital
    y0, y1 = -1.0 + SLAB, 1.0 - SLAB
    bottom, top = [], []
    for k in range(SIDES):
        a = 2 * math.pi * (k + 0.5) / SIDES
        bottom.append(vertex(RADIUS * math.cos(a), y0, -RADIUS * math.sin(a)))
        top.append(vertex(RADIUS * math.cos(a), y1, -RADIUS * math.sin(a)))
    for k in range(SIDES):
        a = 2 * math.pi * (k + 0.5) / SIDES
        lines.append(f"vn {math.cos(a):.6f} 0 {-math.sin(a):.6f}")
    lines.append("s 1")
    for k in range(SIDES):
        j = (k + 1) % SIDES
        # counter-clockwise seen from outside: up the edge k, then across to j
        lines.append(f"f {bottom[k]}//{k + 1} {bottom[j]}//{j + 1} {top[j]}//{j + 1} {top[k]}//{k + 1}")
    lines.append("s off")
    lines.append("f " + " ".join(str(i) for i in top))              # cap, facing +Y
    lines.append("f " + " ".join(str(i) for i in reversed(bottom)))  # cap, facing -Y

    def box(lo, hi):
        c = [vertex(hi[0] if k & 1 else lo[0], hi[1] if k & 2 else lo[1], hi[2] if k & 4 else lo[2])
             for k in range(8)]
        for f in ((0, 4, 6, 2), (1, 3, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (0, 2, 3, 1), (4, 5, 7, 6)):
            lines.append("f " + " ".join(str(c[i]) for i in f))

    lines.append("g base")
    box((-HALF, -1.0, -HALF), (HALF, -1.0 + SLAB, HALF))
    lines.append("g capital")
    box((-HALF, 1.0 - SLAB, -HALF), (HALF, 1.0, HALF))
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
