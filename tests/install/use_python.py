"""The installed Python package, run by tests/test_install.sh with PYTHONPATH set to the
installed package folder alone: it must come from PREFIX and load PREFIX/lib's library, then
sample, bake, render (to numpy and to EXR), compare and read a lit VDB.
Usage: use_python.py PREFIX WORKDIR; prints "python ok" last when every check passed."""
import math
import os
import sys

prefix, work = (os.path.realpath(p) for p in sys.argv[1:3])

import numpy as np  # noqa: E402
import vdbscatter  # noqa: E402


def check(ok, message):
    if not ok:
        sys.exit(f"use_python: FAIL: {message}")


def under(path, folder):
    return os.path.commonpath([os.path.realpath(path), folder]) == folder


check(under(vdbscatter.__file__, prefix),
      f"vdbscatter was imported from {vdbscatter.__file__}, not from {prefix}")
with open("/proc/self/maps", encoding="utf-8") as f:
    loaded = sorted({line.split()[-1] for line in f if "libvdbscatter" in line})
check(len(loaded) == 1 and under(loaded[0], os.path.join(prefix, "lib")),
      f"the loaded libvdbscatter is not {prefix}/lib's: {loaded}")
print("version", vdbscatter.__version__)

density = os.path.join(work, "x.vdb")
lit = os.path.join(work, "lit.vdb")
vdbscatter.sample("cloud", density, res=24, q=True)
check(os.path.isfile(density), "sample wrote no x.vdb")

report = vdbscatter.bake(density, lit, sun="0,-1,0", q=True)
check(isinstance(report, dict) and report, f"bake returned {report!r}, not a report dict")
check(os.path.isfile(lit), "bake wrote no lit.vdb")

image = vdbscatter.render(lit, size=(32, 24))
check(isinstance(image, np.ndarray) and image.shape == (24, 32, 3),
      f"render returned {type(image).__name__} {getattr(image, 'shape', None)}, not (24, 32, 3)")
check(bool(np.all(np.isfinite(image))) and float(image.max()) > 0,
      f"the rendered picture is not finite and positive: max {image.max()}")
print("render", image.shape, "max %.4g" % float(image.max()))

baked_exr = os.path.join(work, "baked.exr")
reference_exr = os.path.join(work, "reference.exr")
vdbscatter.render(lit, baked_exr, size=(32, 24))
vdbscatter.render(density, reference_exr, size=(32, 24), sun="0,-1,0", mode="reference",
                  spp=16)
check(os.path.isfile(baked_exr) and os.path.isfile(reference_exr), "render wrote no EXR")
same = vdbscatter.compare(baked_exr, baked_exr)
check(isinstance(same, dict) and same.get("relrmse") == 0,
      f"compare of a picture with itself: {same!r}")
metrics = vdbscatter.compare(baked_exr, reference_exr)
error = metrics.get("relrmse")
check(isinstance(error, float) and math.isfinite(error) and error > 0,
      f"compare of baked against reference: {metrics!r}")
print("compare relrmse %.4g" % error)

grids = vdbscatter.read_lit(lit)
check(isinstance(grids, dict) and "radiance" in grids and "density" in grids,
      f"read_lit gave the grids {sorted(grids) if isinstance(grids, dict) else grids!r}")
radiance = grids["radiance"].values
check(radiance.ndim == 4 and radiance.shape[3] == 3 and radiance.size > 0,
      f"radiance values have the shape {radiance.shape}")
check(bool(np.all(np.isfinite(radiance))) and float(radiance.max()) > 0,
      "the radiance grid is not finite and positive")
print("read_lit", sorted(grids), "radiance", radiance.shape, "max %.4g" % float(radiance.max()))
print("python ok")
