#!/usr/bin/python3
"""Runs two builds of vdbscatter with identical arguments and checks that every output is
identical: the proof that a restructuring of the library changed nothing.

usage: scripts/compare_builds.py BUILD_A BUILD_B [--out FILE.md] [--keep DIR]
                                [--name-a TEXT] [--name-b TEXT] [--threads N]
                                [--only SUBSTR ...] [--list]

BUILD_* are folders holding a `vdbscatter` executable (A: the reference, e.g. the build
before a refactor; B: the build under test). Everything runs on the C path (`--backend cpu`)
in a temporary folder (kept at DIR with --keep): the inputs (sample volumes, the sky map,
the bundled scene files) in `in/`, each case in `A/CASE/` and `B/CASE/` with the same
command line. Inputs are written by A; a case that needs another case's output (a render of
a lit VDB, a warm start, a comparison of two renders) reads A's copy, so that each
difference shows up in the case that makes it and nowhere downstream.

Per case: equal exit codes (stderr, which carries timings, is ignored) and the same set of
files written, then per file:
  .vdb        the same grids in the same order; per grid the same type, class, background,
              transform, active voxel coordinates (and tiles) and bitwise-equal values
              (every component of vector grids); grid and file metadata equal except timing
              keys (any key containing 'seconds')
  .json       as the --json reports below
  other       (EXR, PNG) equal bytes
stdout: --json reports are equal after dropping timing keys ("seconds" objects and any key
containing 'seconds'): every key of A must be in B and equal; keys that B adds are listed
(allowed); other stdout must be equal text.

Some report values are sums over OpenMP threads added in the order the threads finish (POP's
seeded power, beam loss, residual): they differ in the last digits from run to run of one
build. Where A and B differ, both run the case again on one thread (in A1/ and B1/); if all
outputs are then identical and the differences on several threads were --json report values
only, the case passes and the values are listed. Any other difference (a grid value, an image
byte, an exit code) fails the case, equal on one thread or not.

Prints one line per case (OK, or DIFF and the first difference), then a summary; exits 1
on any difference or on a case that A could not run. --out writes a Markdown table."""
import argparse
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SAMPLES = os.path.join(ROOT, "samples")

IN = "../../in"  # the shared inputs, seen from a case folder
RES = 32         # sample volumes' resolution
SIZE = "80x60"   # rendered images' size

try:
    import pyopenvdb as vdb
except ImportError:  # pragma: no cover - reported at start
    vdb = None


class Case:
    def __init__(self, name, args, what="", stdout="text", publish=()):
        self.name = name        # short id, also the case folder's name
        self.args = args        # argument list after the executable
        self.what = what        # what the case exercises (printed by --list)
        self.stdout = stdout    # "json" (a --json report), "text" or None (ignored)
        self.publish = publish  # files of A's case copied into in/ for later cases


def is_timing(key):
    return "seconds" in key


def scenes():
    return sorted(f[:-5] for f in os.listdir(SAMPLES) if f.endswith(".json"))


def scene_volumes():
    """{scene: the density file it references}: the sample volumes to write."""
    out = {}
    for s in scenes():
        with open(os.path.join(SAMPLES, s + ".json")) as f:
            out[s] = json.load(f)["volume"]["file"]
    return out


def build_cases():
    cases = []
    vols = sorted(set(scene_volumes().values()))
    for v in vols:
        name = v[:-4]
        cases.append(Case(f"sample-{name}", ["sample", name, "--res", str(RES), "-o", v],
                          f"sample {name} --res {RES}", publish=(v,)))
    cases.append(Case("sample-sky", ["sample", "sky", "--res", "16", "-o", "sky.exr"],
                      "sample sky --res 16", publish=("sky.exr",)))
    cpu = ["--backend", "cpu"]
    methods = ["single", "pop", "fld", "svd"]
    # every scene x every method, quality low, the scene's camera (radiance_view)
    for s in scenes():
        for m in methods:
            cases.append(Case(f"bake-{s}-{m}",
                              ["bake", "--scene", f"{IN}/{s}.json", "--method", m, *cpu,
                               "--quality", "low", "-o", "lit.vdb", "--json"],
                              f"bake scene {s}, --method {m}", stdout="json",
                              publish=(("lit.vdb", f"{s}_{m}_lit.vdb"),) if s == "cloud" else ()))
    # S1 by the exact march (the grid path is the default above)
    for m in ("single", "svd"):
        cases.append(Case(f"bake-cloud-{m}-march",
                          ["bake", "--scene", f"{IN}/cloud.json", "--method", m, *cpu,
                           "--s1", "march", "-o", "lit.vdb", "--json"],
                          f"bake scene cloud, --method {m} --s1 march", stdout="json"))
    cases += [
        Case("bake-cloud-svd-s1grid",
             ["bake", "--scene", f"{IN}/cloud.json", "--method", "svd", *cpu, "--s1", "grid",
              "--s1-oversample", "2", "-o", "lit.vdb", "--json"],
             "bake scene cloud, --s1 grid --s1-oversample 2", stdout="json"),
        Case("bake-cube-svd-medium",
             ["bake", "--scene", f"{IN}/cube.json", "--method", "svd", *cpu,
              "--quality", "medium", "-o", "lit.vdb", "--json"],
             "bake scene cube, --method svd --quality medium", stdout="json"),
        Case("bake-cloud-pop-medium",
             ["bake", "--scene", f"{IN}/cloud.json", "--method", "pop", *cpu,
              "--quality", "medium", "-o", "lit.vdb", "--json"],
             "bake scene cloud, --method pop --quality medium", stdout="json"),
        Case("bake-flags-camera",
             ["bake", f"{IN}/smoke.vdb", "--density-scale", "auto:10", "--albedo", "0.9,0.85,0.8",
              "--g", "0.5", "--sun", "-0.5,-0.7,-0.3:2,2,2", "--point", "0.6,-0.6,0.6:1.5,0.8,0.3",
              "--env", "0.1,0.15,0.2", "--camera", "0,0.5,4:0,0,0:40", "--method", "fld", *cpu,
              "-o", "lit.vdb", "--report", "report.json", "--json"],
             "bake from flags (auto:TAU, sun, point, sky, --camera: radiance_view), --report",
             stdout="json"),
        Case("bake-cube-pop-options",
             ["bake", "--scene", f"{IN}/cube.json", "--method", "pop", *cpu, "--pop-importance",
              "--pop-decay", "paper", "--pop-tally", "cell", "--pop-res", "6", "--pop-radial", "8",
              "-o", "lit.vdb", "--json"],
             "bake scene cube, POP importance, paper decay, cell tally", stdout="json"),
        Case("bake-cloud-fld-options",
             ["bake", "--scene", f"{IN}/cloud.json", "--method", "fld", *cpu, "--fld-limiter", "off",
              "--fld-l1", "off", "--fld-p1", "off", "--fld-res", "12", "-o", "lit.vdb", "--json"],
             "bake scene cloud, FLD without limiter, l1, p1", stdout="json"),
        Case("bake-cloud-svd-keep-state",
             ["bake", "--scene", f"{IN}/cloud.json", "--method", "svd", *cpu, "--keep-state",
              "--svd-directions", "32", "--svd-terms", "8", "-o", "state.vdb", "--json"],
             "bake scene cloud, SVD --keep-state (svd_m* grids)", stdout="json",
             publish=(("state.vdb", "cloud_svd_state.vdb"),)),
        Case("bake-cloud-svd-warm-start",
             ["bake", "--scene", f"{IN}/cloud.json", "--method", "svd", *cpu,
              "--warm-start", f"{IN}/cloud_svd_state.vdb", "--svd-directions", "32",
              "--svd-terms", "8", "-o", "lit.vdb", "--json"],
             "bake scene cloud, SVD --warm-start from A's --keep-state bake", stdout="json"),
        Case("bake-cloud-svd-half",
             ["bake", "--scene", f"{IN}/cloud.json", "--method", "svd", *cpu, "--half",
              "-o", "lit.vdb", "--json"],
             "bake scene cloud, --half", stdout="json"),
        Case("bake-cloud-sky-envmap-k",
             ["bake", "--scene", f"{IN}/cloud_sky.json", "--method", "single", *cpu,
              "--sky-directions", "24", "--env", f"{IN}/sky.exr:0.5", "-o", "lit.vdb", "--json"],
             "bake scene cloud_sky, --env FILE:S --sky-directions 24", stdout="json"),
        # renders: of A's lit VDB (cloud, svd), and of the density volume
        Case("render-lit-default",
             ["render", f"{IN}/cloud_svd_lit.vdb", *cpu, "--size", SIZE, "-o", "img.exr", "--json"],
             "render lit VDB, default mode, EXR", stdout="json", publish=(("img.exr", "baked.exr"),)),
        Case("render-lit-baked-png",
             ["render", f"{IN}/cloud_svd_lit.vdb", *cpu, "--mode", "baked", "--size", SIZE,
              "--exposure", "0.5", "-o", "img.png", "--json"],
             "render lit VDB, --mode baked, PNG --exposure 0.5", stdout="json"),
        Case("render-lit-baked-pop-march",
             ["render", f"{IN}/cloud_pop_lit.vdb", *cpu, "--mode", "baked", "--s1", "march",
              "--quality", "medium", "--size", SIZE, "-o", "img.exr", "--json"],
             "render lit VDB (pop), --mode baked --s1 march --quality medium", stdout="json"),
        Case("render-single",
             ["render", f"{IN}/cloud.vdb", "--scene", f"{IN}/cloud.json", *cpu, "--mode", "single",
              "--size", SIZE, "-o", "img.exr", "--json"],
             "render density, --mode single", stdout="json", publish=(("img.exr", "single.exr"),)),
        Case("render-single-sky-camera",
             ["render", f"{IN}/cloud.vdb", "--scene", f"{IN}/cloud_sky.json", *cpu, "--mode", "single",
              "--camera", "0,0.3,4:0,0,0:40", "--size", SIZE, "-o", "img.png", "--json"],
             "render density, --mode single, env map, --camera, PNG", stdout="json"),
        Case("render-reference",
             ["render", f"{IN}/cloud.vdb", "--scene", f"{IN}/cloud.json", *cpu, "--mode", "reference",
              "--spp", "16", "--seed", "7", "--size", SIZE, "-o", "img.exr", "--json"],
             "render density, --mode reference --spp 16 --seed 7 (se.* channels)", stdout="json",
             publish=(("img.exr", "reference.exr"),)),
        Case("render-reference-sky",
             ["render", f"{IN}/cloud.vdb", "--scene", f"{IN}/cloud_sky.json", *cpu, "--mode",
              "reference", "--spp", "8", "--seed", "3", "--max-bounces", "64", "--size", SIZE,
              "-o", "img.exr", "--json"],
             "render density, --mode reference, env map NEE, --max-bounces 64", stdout="json"),
        Case("render-reference-sky-nee-off",
             ["render", f"{IN}/cloud.vdb", "--scene", f"{IN}/cloud_sky.json", *cpu, "--mode",
              "reference", "--spp", "8", "--seed", "3", "--env-nee", "off", "--size", SIZE,
              "-o", "img.png", "--json"],
             "render density, --mode reference --env-nee off, PNG", stdout="json"),
        # compare, info, phase-svd
        Case("compare-json",
             ["compare", f"{IN}/baked.exr", f"{IN}/reference.exr", "--json"],
             "compare baked EXR against reference EXR (with se.*), --json", stdout="json"),
        Case("compare-text-mask",
             ["compare", f"{IN}/single.exr", f"{IN}/baked.exr", "--mask-below", "0.01"],
             "compare two EXRs, --mask-below, key=value text", stdout="text"),
        Case("info-lit",
             ["info", f"{IN}/cloud_svd_lit.vdb", "--json"], "info --json of a lit VDB", stdout="json"),
        Case("info-density",
             ["info", f"{IN}/cloud.vdb", "--density-scale", "20", "--target-depth", "10", "--json"],
             "info --json --density-scale --target-depth", stdout="json"),
        Case("info-text",
             ["info", f"{IN}/cube.vdb", "--density-scale", "3"], "info, text", stdout="text"),
        Case("phase-svd",
             ["phase-svd", "--g", "0.85", "--directions", "64", "--json"],
             "phase-svd --g 0.85 --directions 64 --json", stdout="json"),
        Case("phase-svd-delta-m-off",
             ["phase-svd", "--g", "0.5", "--directions", "48", "--delta-m", "off", "--json"],
             "phase-svd --delta-m off --json", stdout="json"),
    ]
    return cases


# ---------------------------------------------------------------- JSON

def fmt(v):
    s = json.dumps(v)
    return s if len(s) <= 60 else s[:57] + "..."


def same_scalar(a, b):
    if type(a) is not type(b):
        return False
    if isinstance(a, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def json_compare(a, b, path, diffs, added):
    """Every key of A (timing keys dropped) equal in B: each difference goes to diffs as
    (path, message), each key that B adds to added."""
    if isinstance(a, dict):
        if not isinstance(b, dict):
            diffs.append((path, f"{path or '/'}: A is an object, B {fmt(b)}"))
            return
        for k, va in a.items():
            if is_timing(k):
                continue
            p = f"{path}.{k}" if path else k
            if k not in b:
                diffs.append((p, f"{p}: missing in B (A {fmt(va)})"))
            else:
                json_compare(va, b[k], p, diffs, added)
        for k in b:
            if k not in a and not is_timing(k):
                added.append(f"{path}.{k}" if path else k)
    elif isinstance(a, list):
        if not isinstance(b, list) or len(a) != len(b):
            diffs.append((path, f"{path}: A {fmt(a)}, B {fmt(b)}"))
            return
        for i, (va, vb) in enumerate(zip(a, b)):
            json_compare(va, vb, f"{path}[{i}]", diffs, added)
    elif not same_scalar(a, b):
        diffs.append((path, f"{path}: A {fmt(a)}, B {fmt(b)}"))


def compare_json_text(ta, tb, label):
    """([(key, message)] of every difference, [keys B adds]) of two JSON texts."""
    try:
        ja = json.loads(ta)
    except ValueError as e:
        return [(("json", label), f"{label}: A's is not JSON ({e})")], []
    try:
        jb = json.loads(tb)
    except ValueError as e:
        return [(("json", label), f"{label}: B's is not JSON ({e})")], []
    diffs, added = [], []
    json_compare(ja, jb, "", diffs, added)
    return [(("json", label, p), f"{label}: {m}") for p, m in diffs], added


# ---------------------------------------------------------------- VDB

def bits(v):
    """The exact bits of a value read from a grid (floats are float32 or half widened to
    double, which keeps every bit), as a hashable key; vectors component by component."""
    if isinstance(v, tuple):
        return tuple(bits(c) for c in v)
    if isinstance(v, float):
        return struct.pack("<d", v)
    return v


def meta_clean(meta):
    return {k: v for k, v in meta.items() if not is_timing(k)}


def meta_diff(ma, mb, label):
    ma, mb = meta_clean(ma), meta_clean(mb)
    for k in sorted(set(ma) | set(mb)):
        if k not in mb:
            return f"{label} key {k}: missing in B"
        if k not in ma:
            return f"{label} key {k}: only in B ({fmt(str(mb[k]))})"
        if bits(ma[k]) != bits(mb[k]):
            va, vb = str(ma[k]), str(mb[k])
            i = next((j for j in range(min(len(va), len(vb))) if va[j] != vb[j]),
                     min(len(va), len(vb)))
            if i > 20:  # long strings (the scene's JSON): from just before the first difference
                return (f"{label} {k} at character {i}: A ...{fmt(va[i - 20:])}, "
                        f"B ...{fmt(vb[i - 20:])}")
            return f"{label} {k}: A {fmt(va)}, B {fmt(vb)}"
    return None


def transform_key(g):
    t = g.transform
    pts = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (7, -3, 11)]
    return (t.typeName, bits(tuple(float(c) for c in t.voxelSize())),
            tuple(bits(tuple(float(c) for c in t.indexToWorld(p))) for p in pts))


def active_items(g):
    """[(min, max, depth, value bits)] of every active voxel and tile, in tree order."""
    return [(it.min, it.max, it.depth, bits(it.value)) for it in g.citerOnValues()]


def compare_vdb(pa, pb):
    """(first difference or None, number of grids) of two VDB files."""
    ga, fa = vdb.readAll(pa)
    gb, fb = vdb.readAll(pb)
    na, nb = [g.name for g in ga], [g.name for g in gb]
    if na != nb:
        return f"grids: A {na}, B {nb}", len(ga)
    m = meta_diff(fa, fb, "file metadata")
    if m:
        return m, len(ga)
    for a, b in zip(ga, gb):
        n = a.name
        for attr in ("valueTypeName", "gridClass", "vectorType", "saveFloatAsHalf", "creator"):
            va, vb = getattr(a, attr), getattr(b, attr)
            if va != vb:
                return f"grid {n} {attr}: A {va}, B {vb}", len(ga)
        if bits(a.background) != bits(b.background):
            return f"grid {n} background: A {a.background}, B {b.background}", len(ga)
        if transform_key(a) != transform_key(b):
            return f"grid {n} transform differs", len(ga)
        m = meta_diff(dict(a.metadata), dict(b.metadata), f"grid {n} metadata")
        if m:
            return m, len(ga)
        ia, ib = active_items(a), active_items(b)
        if len(ia) != len(ib):
            return (f"grid {n}: {len(ia)} active voxels/tiles in A, {len(ib)} in B "
                    f"(voxels {a.activeVoxelCount()} vs {b.activeVoxelCount()})"), len(ga)
        for x, y in zip(ia, ib):
            if x[:3] != y[:3]:
                return f"grid {n}: active coordinates differ: A {x[0]}, B {y[0]}", len(ga)
            if x[3] != y[3]:
                va = a.getConstAccessor().getValue(x[0])
                vb = b.getConstAccessor().getValue(y[0])
                return f"grid {n} value at {x[0]}: A {va!r}, B {vb!r}", len(ga)
    return None, len(ga)


# ---------------------------------------------------------------- files

def compare_bytes(pa, pb):
    with open(pa, "rb") as f:
        da = f.read()
    with open(pb, "rb") as f:
        db = f.read()
    if da == db:
        return None
    i = next((k for k in range(min(len(da), len(db))) if da[k] != db[k]), min(len(da), len(db)))
    return f"bytes differ (A {len(da)} B, B {len(db)} B, first at offset {i})"


def list_files(d):
    out = []
    for root, _, files in os.walk(d):
        for f in files:
            if f in ("stdout", "stderr"):
                continue
            out.append(os.path.relpath(os.path.join(root, f), d))
    return sorted(out)


def run_case(exe, case, cwd, threads=None):
    os.makedirs(cwd, exist_ok=True)
    env = dict(os.environ, LC_ALL="C")
    if threads:
        env["OMP_NUM_THREADS"] = str(threads)
    t = time.monotonic()
    with open(os.path.join(cwd, "stdout"), "wb") as so, open(os.path.join(cwd, "stderr"), "wb") as se:
        p = subprocess.run([exe, *case.args], cwd=cwd, stdout=so, stderr=se, env=env)
    with open(os.path.join(cwd, "stdout"), encoding="utf-8", errors="replace") as f:
        out = f.read()
    return p.returncode, out, time.monotonic() - t


def stderr_tail(cwd):
    try:
        with open(os.path.join(cwd, "stderr"), encoding="utf-8", errors="replace") as f:
            lines = [l.strip() for l in f if l.strip()]
        return lines[-1] if lines else ""
    except OSError:
        return ""


def compare_case(case, da, db, ra, rb, oa, ob):
    """([(key, message)] of every difference, compared outputs [str], keys B adds [str]).
    A key names what differs (a JSON path, a file) so that differences can be matched
    against those between two runs of A."""
    diffs, compared, added = [], [], []
    if ra != rb:
        return [(("exit",), f"exit code A {ra}, B {rb}")], compared, added
    compared.append("exit code")
    if case.stdout == "json":
        d, add = compare_json_text(oa, ob, "stdout")
        diffs += d
        added += [f"stdout {k}" for k in add]
        compared.append("stdout JSON")
    elif case.stdout == "text" and not oa and not ob:
        compared.append("stdout (empty)")
    elif case.stdout == "text":
        if oa != ob:
            la, lb = oa.splitlines(), ob.splitlines()
            i = next((k for k in range(min(len(la), len(lb))) if la[k] != lb[k]),
                     min(len(la), len(lb)))
            diffs.append((("stdout",), f"stdout line {i + 1}: "
                          f"A {fmt(la[i] if i < len(la) else '<end>')}, "
                          f"B {fmt(lb[i] if i < len(lb) else '<end>')}"))
        compared.append("stdout text")
    fa, fb = list_files(da), list_files(db)
    if fa != fb:
        diffs.append((("files",), f"files written: A {fa}, B {fb}"))
    for f in fa:
        if f not in fb:
            continue
        pa, pb = os.path.join(da, f), os.path.join(db, f)
        ext = os.path.splitext(f)[1].lower()
        if ext == ".vdb":
            d, n = compare_vdb(pa, pb)
            if d:
                diffs.append((("file", f), f"{f}: {d}"))
            compared.append(f"{f} ({n} grid{'s' if n != 1 else ''})")
        elif ext == ".json":
            with open(pa) as x, open(pb) as y:
                d, add = compare_json_text(x.read(), y.read(), f)
            diffs += d
            added += [f"{f} {k}" for k in add]
            compared.append(f"{f} (JSON)")
        else:
            d = compare_bytes(pa, pb)
            if d:
                diffs.append((("file", f), f"{f}: {d}"))
            compared.append(f"{f} (bytes)")
    return diffs, compared, added


def md_escape(s):
    return s.replace("|", "\\|").replace("\n", " ")


def main():
    ap = argparse.ArgumentParser(description="\n\n".join(
        p for p in __doc__.split("\n\n") if not p.startswith("usage:")),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", metavar="BUILD_A", help="folder with the reference vdbscatter")
    ap.add_argument("b", metavar="BUILD_B", help="folder with the vdbscatter under test")
    ap.add_argument("--out", metavar="FILE.md", help="write a Markdown table of the cases")
    ap.add_argument("--keep", metavar="DIR", help="run in DIR and keep it (default: a temp "
                    "folder, removed at the end)")
    ap.add_argument("--name-a", metavar="TEXT", help="what A is, for the table (default: BUILD_A)")
    ap.add_argument("--name-b", metavar="TEXT", help="what B is, for the table (default: BUILD_B)")
    ap.add_argument("--threads", type=int, metavar="N",
                    help="OMP_NUM_THREADS for both builds (default: OpenMP's default)")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--only", metavar="SUBSTR", action="append",
                    help="run only the cases whose name contains SUBSTR (repeatable; the cases "
                    "they read from in/ must be selected too)")
    args = ap.parse_args()
    if args.list:
        for c in build_cases():
            if not args.only or any(x in c.name for x in args.only):
                print(f"{c.name}: {c.what}\n    vdbscatter {' '.join(c.args)}")
        return
    if vdb is None:
        sys.exit("compare_builds.py: needs pyopenvdb (run it with /usr/bin/python3)")
    exes = [os.path.abspath(os.path.join(d, "vdbscatter")) for d in (args.a, args.b)]
    for e in exes:
        if not os.access(e, os.X_OK):
            sys.exit(f"compare_builds.py: no executable {e}")
    if args.keep:
        tmp = os.path.abspath(args.keep)
        if os.path.isdir(tmp) and set(os.listdir(tmp)) <= {"in", "A", "B", "A1", "B1"}:
            shutil.rmtree(tmp)  # empty, or a previous run's folder
        elif os.path.exists(tmp):
            sys.exit(f"compare_builds.py: --keep {tmp}: exists and is not a previous run's folder")
        os.makedirs(tmp)
    else:
        tmp = tempfile.mkdtemp(prefix="compare-builds-")
    ind = os.path.join(tmp, "in")
    os.makedirs(ind)
    for f in os.listdir(SAMPLES):  # scene files and what they reference besides volumes
        if f.endswith((".json", ".obj")):
            shutil.copy(os.path.join(SAMPLES, f), ind)

    cases = build_cases()
    if args.only:
        cases = [c for c in cases if any(x in c.name for x in args.only)]
    t0 = time.monotonic()
    rows, added, threaded = [], {}, []
    nfail = 0
    counts = dict(vdb=0, grids=0, image=0, json=0, text=0)
    times = [0.0, 0.0]
    for case in cases:
        dirs = [os.path.join(tmp, x, case.name) for x in ("A", "B", "A1", "B1")]
        res = []
        for i in range(2):
            rc, out, dt = run_case(exes[i], case, dirs[i], args.threads)
            times[i] += dt
            res.append((rc, out))
        for p in case.publish:
            src, dst = (p, p) if isinstance(p, str) else p
            if os.path.exists(os.path.join(dirs[0], src)):
                shutil.copy(os.path.join(dirs[0], src), os.path.join(ind, dst))
        (ra, oa), (rb, ob) = res
        varies, one_thread = [], None
        if ra != 0 and ra == rb:
            status, note, compared = "ERROR", f"both exit {ra}: {stderr_tail(dirs[0])}", []
        else:
            diffs, compared, add = compare_case(case, dirs[0], dirs[1], ra, rb, oa, ob)
            for k in add:
                added.setdefault(k, []).append(case.name)
            if diffs:
                # Both again on one thread: report values that are sums over threads (added
                # in the order the threads finish) vary from run to run even within one build.
                # If everything is equal on one thread and the differences on several threads
                # are report values only, the case passes and those values are listed.
                r1 = [run_case(exes[i], case, dirs[2 + i], 1)[:2] for i in range(2)]
                d1, _, _ = compare_case(case, dirs[2], dirs[3], r1[0][0], r1[1][0],
                                        r1[0][1], r1[1][1])
                one_thread = not d1
                if one_thread and all(k[0] == "json" and len(k) == 3 for k, _ in diffs):
                    varies = [m.split(": A ")[0] for _, m in diffs]
                    diffs = []
            status = "DIFF" if diffs else "OK"
            note = diffs[0][1] if diffs else ""
            if len(diffs) > 1:
                note += f" (and {len(diffs) - 1} more)"
            in_files = [(k, m) for k, m in diffs
                        if k[0] == "file" or (k[0] == "json" and k[1] != "stdout")]
            if in_files and in_files[0] != diffs[0]:
                note += "; files that differ: " + ", ".join(sorted({k[1] for k, _ in in_files}))
                note += "; " + in_files[0][1]
            if diffs and one_thread:
                note += "; equal on one thread"
            if varies:
                threaded.append((case.name, varies))
                note = ("report values differ on several threads, all equal on one: "
                        + ", ".join(varies))
        for c in compared:
            kind = ("vdb" if ".vdb (" in c else "json" if c.endswith("(JSON)") or c == "stdout JSON"
                    else "image" if c.endswith("(bytes)") else "text" if c == "stdout text" else None)
            if kind:
                counts[kind] += 1
            if kind == "vdb":
                counts["grids"] += int(c.rsplit("(", 1)[1].split()[0])
        if status != "OK":
            nfail += 1
        print(f"{status:5s} {case.name}" + (f": {note}" if note else ""), flush=True)
        rows.append((case, status, note, compared))
    wall = time.monotonic() - t0

    threads = args.threads or os.environ.get("OMP_NUM_THREADS") or len(os.sched_getaffinity(0))
    noutputs = counts["vdb"] + counts["image"] + counts["json"] + counts["text"]
    summary = (f"{len(rows)} cases, {noutputs} outputs compared ({counts['vdb']} VDB files with "
               f"{counts['grids']} grids, {counts['image']} images, {counts['json']} JSON reports, "
               f"{counts['text']} text outputs) besides the exit codes: {len(rows) - nfail} cases "
               f"identical, {nfail} different or failed; {len(threaded)} of the identical ones "
               f"with report values equal only on one thread; {len(added)} report keys added by "
               f"B; {wall:.0f} s "
               f"(A {times[0]:.0f} s, B {times[1]:.0f} s) on {threads} threads")
    print(summary)
    if added:
        print("keys added by B (allowed): " + ", ".join(sorted(added)))
    if args.out:
        write_table(args.out, rows, added, threaded, summary,
                    args.name_a or args.a, args.name_b or args.b)
    if not args.keep:
        shutil.rmtree(tmp, ignore_errors=True)
    else:
        print(f"kept {tmp}")
    sys.exit(1 if nfail else 0)


def write_table(path, rows, added, threaded, summary, name_a, name_b):
    with open(path, "w") as f:
        f.write("# Identical outputs: two builds side by side\n\n")
        f.write(f"A: {name_a}. B: {name_b}.\n\n")
        f.write("Written by `scripts/compare_builds.py BUILD_A BUILD_B --out FILE.md`. Both builds "
                "run the same command lines on the C path (`--backend cpu`); sample volumes at "
                f"{RES}^3, images {SIZE}. Exit codes must be equal; lit VDBs are compared grid by "
                "grid (active voxels and tiles, bitwise values, grid and file metadata without "
                "timing keys), images by their bytes, `--json` reports key by key without timing "
                "keys (keys B adds are listed below, not failures), other stdout as text; stderr "
                "is ignored. Where A and B differ, both run the case again on one thread "
                "(`OMP_NUM_THREADS=1`): a case whose outputs are then all identical and whose "
                "differences on several threads are `--json` report values only (sums over "
                "threads, added in the order the threads finish, which vary from run to run of "
                "one build too) passes, and those values are listed below.\n\n")
        f.write(f"{summary}.\n\n")
        f.write("| case | command (after `vdbscatter`) | compared | result |\n|---|---|---|---|\n")
        for case, status, note, compared in rows:
            cmd = " ".join(a.replace(IN + "/", "") for a in case.args)
            res = status + (f": {note}" if note else "")
            f.write(f"| {case.name} | `{md_escape(cmd)}` | {md_escape(', '.join(compared))} | "
                    f"{md_escape(res)} |\n")
        f.write("\nInput paths are relative to the inputs folder: the sample volumes and the sky "
                "map written by A's `sample` cases, the bundled scene files, and A's outputs of "
                "earlier cases (`cloud_*_lit.vdb`, `cloud_svd_state.vdb`, `baked.exr`, "
                "`single.exr`, `reference.exr`).\n\n## Keys added by B\n\n")
        if added:
            for k, cs in sorted(added.items()):
                f.write(f"- `{k}` ({len(cs)} case{'s' if len(cs) > 1 else ''})\n")
        else:
            f.write("None.\n")
        f.write("\n## Report values equal only on one thread\n\n")
        if threaded:
            for name, varies in threaded:
                f.write(f"- {name}: {', '.join(varies)}\n")
        else:
            f.write("None.\n")


if __name__ == "__main__":
    main()
