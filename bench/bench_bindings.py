#!/usr/bin/env python3
"""The Python package against the CLI, side by side in one run: what a call costs beyond the
work (a process and its library load per CLI call, nothing per in-process call), that a bake
and a render cost the same either way, and read_lit (the library's dense copy) against
pyopenvdb's readAll + copyToArray on the same lit VDB.

usage: bench/bench_bindings.py BUILD_DIR [--repeats N] [-o bench/bindings.md]
Needs the build's libvdbscatter.so.0 and /usr/bin/python3 with numpy (pyopenvdb optional)."""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def median_seconds(fn, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def cli(exe, *args):
    subprocess.run([exe, *args], check=True, capture_output=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("build")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("-o", "--output", default=os.path.join(HERE, "bindings.md"))
    a = ap.parse_args()
    build = os.path.abspath(a.build)
    exe = os.path.join(build, "vdbscatter")
    os.environ["VDBSCATTER_LIBRARY"] = os.path.join(build, "libvdbscatter.so.0")
    sys.path.insert(0, os.path.join(ROOT, "python"))
    import vdbscatter

    tmp = tempfile.mkdtemp(prefix="bench_bindings.")
    vdb = os.path.join(ROOT, "samples", "cloud.vdb")
    scene = os.path.join(ROOT, "samples", "cloud.json")
    lit = os.path.join(tmp, "lit.vdb")
    exr = os.path.join(tmp, "img.exr")
    r = a.repeats
    rows = []

    def pair(what, cli_args, call):
        cli(exe, *cli_args)  # warm the file cache and the caches of both sides alike
        call()
        t_cli = median_seconds(lambda: cli(exe, *cli_args), r)
        t_py = median_seconds(call, r)
        rows.append((what, t_cli, t_py))
        print(f"{what}: CLI {t_cli:.3f} s, Python {t_py:.3f} s")

    pair("info --json (a call's cost)", ["info", vdb, "--json"], lambda: vdbscatter.info(vdb))
    pair("bake, cloud sample, defaults", ["bake", vdb, "--scene", scene, "-o", lit, "-q"],
         lambda: vdbscatter.bake(vdb, lit, scene=scene, q=True))
    pair("render 320x240 of the lit VDB", ["render", lit, "--size", "320x240", "-o", exr, "-q"],
         lambda: vdbscatter.render(lit, size=(320, 240), q=True))

    grids = vdbscatter.read_lit(lit)
    mib = sum(g.values.nbytes for g in grids.values()) / 2**20
    t_lib = median_seconds(lambda: vdbscatter.read_lit(lit), r)
    t_pyvdb = None
    try:
        import numpy as np
        import pyopenvdb

        def with_pyopenvdb():
            for grid in pyopenvdb.readAll(lit)[0]:
                if grid.name not in grids:
                    continue
                lo, hi = grid.evalActiveVoxelBoundingBox()
                shape = tuple(h - l + 1 for l, h in zip(lo, hi))
                shape = shape + ((3,) if grids[grid.name].values.ndim == 4 else ())
                array = np.zeros(shape, dtype=np.float32)
                grid.copyToArray(array, ijk=lo)

        t_pyvdb = median_seconds(with_pyopenvdb, r)
    except ImportError:
        pass
    print(f"read_lit: {t_lib:.3f} s for {mib:.1f} MiB; pyopenvdb: {t_pyvdb}")

    with open(a.output, "w") as f:
        f.write("# The Python package against the CLI\n\n")
        f.write(f"`/usr/bin/python3 bench/bench_bindings.py BUILD` (medians of {r}; "
                "samples/cloud.vdb with samples/cloud.json, C path). CLI: one process per "
                "call; Python: `vdbscatter.*` in one process.\n\n")
        f.write("| work | CLI s | Python s | Python / CLI |\n|---|---|---|---|\n")
        for what, t_cli, t_py in rows:
            f.write(f"| {what} | {t_cli:.3f} | {t_py:.3f} | {t_py / t_cli:.2f} |\n")
        f.write(f"\nReading the lit VDB's {len(grids)} float and vec3s grids into dense numpy "
                f"arrays ({mib:.1f} MiB): `read_lit` {t_lib:.3f} s")
        if t_pyvdb is not None:
            f.write(f"; pyopenvdb `readAll` + `copyToArray` {t_pyvdb:.3f} s "
                    f"(read_lit / pyopenvdb {t_lib / t_pyvdb:.2f})")
        f.write(".\n\nread_lit goes through the reader that every file the tool opens goes "
                "through: a child process parses the file and streams the grids back, so that a "
                "hostile file cannot take the caller down (docs/robustness.md); the file is "
                "also listed once before it is read. pyopenvdb reads it once, in process.\n")
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
