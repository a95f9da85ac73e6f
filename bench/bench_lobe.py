#!/usr/bin/python3
"""How much of a lit VDB's picture error is its format's: the solver's moments against the exact
ones, and the exact moments read back as one HG lobe (the renderer's reconstruction), as an
isotropic part plus a lobe fitted to the second moment, and as an isotropic part plus a beam.

Per scene (96x72 from the scene's camera, or the renderer's default one): the method is baked at
`medium`; the Monte-Carlo probe (vdbs_reference_probe_moments, through build/bench/
bench_moments) estimates ms, ms_l1 and the second moment ms_t2 over a ball of one voxel's volume
around every output voxel; lit VDBs with those moments in place of the solver's are rendered and
compared with a reference image (`render --mode reference --tolerance`). Rows:

  solver          the bake as it is
  exact           the probe's ms and ms_l1 in the lit VDB: the renderer's one lobe
  exact, view     the same lobe toward the camera, written as an isotropic ms (so the three
                  shapes below compare like for like: the camera's direction at each voxel
                  centre, interpolated as the grids are)
  exact, 3 mom.   isotropic part 1 - beta plus an HG lobe of mean cosine b' (toward the camera):
                  with mu the light's mean cosine and p2 its second Legendre moment along the
                  flux, b' = p2 / mu and beta = mu^2 / p2 (p2 held within [mu^2, mu])
  exact, beam     p2 = mu: an isotropic part plus a beam

usage: bench/bench_lobe.py BUILD [--out bench/lobe.md] [--scenes cloud,sphere_env,...]
       [--methods svd] [--photons 16000000] [--ref-noise 0.01] [--work DIR]
Scenes are bench_calibrate.py's, by name (VDBSCATTER_DATA_DIR: the data folder)."""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

from bench_calibrate import CALIBRATION, VALIDATION
from benchlib import run_json

HERE = os.path.dirname(os.path.abspath(__file__))


def voxel_points(lit):
    """Index coordinates and world centres of the lit VDB's output voxels (the ms grid)."""
    import pyopenvdb
    grid = pyopenvdb.read(lit, "ms")
    ijk = [it.min for it in grid.citerOnValues() if it.count == 1]
    xf = grid.transform
    return ijk, np.array([xf.indexToWorld(c) for c in ijk], dtype=np.float64)


def toward_camera(ms, l1, t2, g, wo, shape):
    """Sms toward wo per voxel and channel from the moments, for a shape: 'lobe' (p2 = mu^2,
    the renderer's), 'fit' (p2 from the second moment) or 'beam' (p2 = mu)."""
    out = np.array(ms)
    if g <= 0.0:
        return out
    for c in range(3):
        m = ms[:, c]
        flux = l1[:, :, c] / (3.0 * g)               # (1 / 4 pi) integral L w dw
        fl = np.linalg.norm(flux, axis=1)
        ok = (m > 0.0) & (fl > 1e-12 * np.maximum(m, 1e-30))
        n = flux / np.where(ok, fl, 1.0)[:, None]
        mu = np.clip(np.where(ok, fl / np.where(ok, m, 1.0), 0.0), 0.0, 0.999)
        tc = t2[:, :, c] / np.where(ok, m, 1.0)[:, None]  # xx yy zz xy xz yz over ms
        nn = (n[:, 0] ** 2 * tc[:, 0] + n[:, 1] ** 2 * tc[:, 1] + n[:, 2] ** 2 * tc[:, 2] +
              2 * (n[:, 0] * n[:, 1] * tc[:, 3] + n[:, 0] * n[:, 2] * tc[:, 4] +
                   n[:, 1] * n[:, 2] * tc[:, 5]))
        p2 = {"lobe": mu * mu, "beam": mu, "fit": 0.5 * (3.0 * nn - 1.0)}[shape]
        p2 = np.clip(p2, mu * mu, np.maximum(mu, 1e-12))
        beta = np.where(p2 > 0.0, mu * mu / np.maximum(p2, 1e-30), 1.0)
        b = np.minimum(g * np.where(mu > 0.0, p2 / np.maximum(mu, 1e-30), 0.0), 0.999)
        cosw = np.sum(n * wo, axis=1)
        d = 1.0 + b * b - 2.0 * b * cosw
        lobe = (1.0 - b * b) / (d * np.sqrt(d))      # 4 pi f_hg
        out[:, c] = np.where(ok, m * ((1.0 - beta) + beta * lobe), m)
    return out


def write_lit(src, dst, ijk, ms, l1):
    """A copy of the lit VDB `src` with ms and ms_l1x/y/z set at its output voxels."""
    import pyopenvdb
    grids, meta = pyopenvdb.readAll(src)
    by = {gr.name: gr for gr in grids}
    for name, vals in (("ms", ms), ("ms_l1x", l1[:, 0, :]), ("ms_l1y", l1[:, 1, :]),
                       ("ms_l1z", l1[:, 2, :])):
        acc = by[name].getAccessor()
        for c, v in zip(ijk, vals):
            acc.setValueOn(c, (float(v[0]), float(v[1]), float(v[2])))
    pyopenvdb.write(dst, grids=grids, metadata=meta)


def compare(exe, img, ref):
    rep = run_json([exe, "compare", img, ref, "--json"])
    return rep["relrmse"], rep["mean_ratio"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("build")
    ap.add_argument("--out", default=os.path.join(HERE, "lobe.md"))
    ap.add_argument("--scenes", default="cloud,cloud_sky,sphere_env,thick_cube,smoke_sky,"
                                       "smoke_thin,usd_smoke,usd_heat")
    ap.add_argument("--methods", default="svd")
    ap.add_argument("--photons", type=int, default=16000000)
    ap.add_argument("--ref-noise", default="0.01")
    ap.add_argument("--size", default="96x72")
    ap.add_argument("--work", help="keep the work files here (default: a temporary folder)")
    args = ap.parse_args()
    exe = os.path.join(args.build, "vdbscatter")
    probe = os.path.join(args.build, "bench", "bench_moments")
    work = args.work or tempfile.mkdtemp(prefix="bench_lobe-")
    os.makedirs(work, exist_ok=True)
    table = {**CALIBRATION, **VALIDATION}  # the calibration's scenes, by name
    rows = []
    for name in args.scenes.split(","):
        scene, vdb, what = table[name]
        if vdb and not os.path.exists(vdb):
            print(f"{name}: {vdb} missing, skipped")
            continue
        inp = [vdb] if vdb else []
        g = json.load(open(scene))["volume"].get("g", 0.0)
        ref = os.path.join(work, f"{name}-ref.exr")
        if not os.path.exists(ref):
            run_json([exe, "render", *inp, "--scene", scene, "--mode", "reference",
                      "--tolerance", args.ref_noise, "--size", args.size, "--backend", "cpu",
                      "-o", ref, "--json", "-q"])
        moments = None
        for method in args.methods.split(","):
            lit = os.path.join(work, f"{name}-{method}.vdb")
            bake = run_json([exe, "bake", *inp, "--scene", scene, "--method", method,
                             "--quality", "medium", "--backend", "cpu", "-o", lit, "--json",
                             "-q"])

            def render(path):
                img = path[:-4] + ".exr"
                rep = run_json([exe, "render", path, "--size", args.size, "--backend", "cpu",
                                "-o", img, "--json", "-q"])
                return img, rep

            img, rep = render(lit)
            eye = np.array(rep["camera"]["position"], dtype=np.float64)
            ijk, pts = voxel_points(lit)
            if moments is None:  # the exact moments depend on the scene only
                pf = os.path.join(work, f"{name}-points.f64")
                mf = os.path.join(work, f"{name}-moments.f64")
                pts.tofile(pf)
                subprocess.run([probe, *(inp or [bake["input"]]), scene, pf, mf,
                                "--density-scale", str(bake["density_scale"]), "--photons",
                                str(args.photons)], check=True)
                n = len(pts)
                raw = np.fromfile(mf, dtype=np.float64)
                v, se = raw[:30 * n], raw[30 * n:]
                moments = (v[:3 * n].reshape(n, 3), v[3 * n:12 * n].reshape(n, 3, 3),
                           v[12 * n:].reshape(n, 6, 3),
                           float(np.median(se[:3 * n].reshape(n, 3)[:, 1] /
                                           np.maximum(v[:3 * n].reshape(n, 3)[:, 1], 1e-30))))
            ms, l1, t2, noise = moments
            wo = eye[None, :] - pts
            wo /= np.linalg.norm(wo, axis=1)[:, None]
            zero = np.zeros_like(l1)
            row = {"scene": name, "what": what, "method": method, "probe_noise": noise,
                   "solver": compare(exe, img, ref)}
            for key, ms_v, l1_v in (
                    ("exact", ms, l1),
                    ("exact_view", toward_camera(ms, l1, t2, g, wo, "lobe"), zero),
                    ("exact_fit", toward_camera(ms, l1, t2, g, wo, "fit"), zero),
                    ("exact_beam", toward_camera(ms, l1, t2, g, wo, "beam"), zero)):
                path = os.path.join(work, f"{name}-{method}-{key}.vdb")
                write_lit(lit, path, ijk, ms_v, l1_v)
                row[key] = compare(exe, render(path)[0], ref)
            rows.append(row)
            print(json.dumps(row), flush=True)
    with open(args.out, "w") as f:
        f.write("# The lit VDB's lobe: the solver's moments against exact ones\n\n"
                f"`bench/bench_lobe.py` ({args.size}, references to a relative noise of "
                f"{args.ref_noise}, {args.photons} probe photons). Relative RMSE (mean ratio) "
                "against the reference; columns as the script's docstring says.\n\n"
                "| scene | method | solver | exact | exact, view | exact, 3 mom. | exact, beam |"
                " probe noise |\n|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            cells = " | ".join(f"{r[k][0]:.4f} ({r[k][1]:.3f})" for k in
                               ("solver", "exact", "exact_view", "exact_fit", "exact_beam"))
            f.write(f"| {r['scene']} ({r['what']}) | {r['method']} | {cells} | "
                    f"{r['probe_noise']:.3f} |\n")
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    sys.exit(main())
