#!/usr/bin/python3
"""Frame sequences (docs/sequences.md) on small frames of `sample smoke --time` (the light
twin of test_sequence_cli, also run under the sanitizers): frame numbers and rates in the
metadata, missing frames listed (exit 2, no output) or skipped, a corrupt frame (exit 3, the
others baked), --verify after a failed frame (exit 3), malformed patterns, lists and flags
(one line, exit 2), the render of a sequence, and inet's warm starts."""
import json
import os
import shutil
import unittest

from sequencelib import SCENE, Shot, grids, ms_rms, run


class Sequence(Shot):
    FRAMES = 6
    RES = 32

    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        cls.cold = cls.bake_sequence("cold", "--no-warm-start")

    def test_metadata_carries_frame_rate_and_hash(self):
        folder = "fps"
        os.makedirs(os.path.join(self.tmp, folder))
        run("bake", self.input, "-o", self.out(folder, "lit.$F.vdb"), *SCENE, "--frames",
            "2-6x4", "--fps", "24", "-q")
        self.assertEqual(sorted(os.listdir(os.path.join(self.tmp, folder))),
                         ["lit.2.vdb", "lit.6.vdb"])
        _, meta = grids(self.out(folder, "lit.6.vdb"))
        self.assertEqual((meta["vdbscatter_frame"], meta["vdbscatter_fps"]), ("6", "24"))
        self.assertRegex(meta["vdbscatter_hash"], r"^[0-9a-f]{32}$")
        # frame 6 started from frame 2, the previous frame of the list
        self.assertEqual(meta["vdbscatter_warm_start"], "lit.2.vdb")

    def test_inet_frames_warm_start(self):
        """--method inet keeps its state (D grids a frame) in a sequence only with --keep-state;
        then each frame starts from the previous one's (the report's inet.warm_start, the
        file's vdbscatter_warm_start) in fewer sweeps than a cold start (frames 1-4; measured
        275 against 328 over frames 2-4, each frame fewer: the particles are resampled every
        frame, so the per-voxel state starts them less well than the same particles), ms within
        1e-3 relative RMS of the cold frame's (measured at most 8e-5). Without it every frame
        starts cold and keeps no inet_r grids."""
        inet = [a if a != "svd" else "inet" for a in SCENE]
        runs = {}
        for folder, extra in (("inet_warm", ["--keep-state"]), ("inet_cold", [])):
            os.makedirs(os.path.join(self.tmp, folder))
            p = run("bake", self.input, "-o", self.out(folder), *inet, *extra, "--frames", "1-4",
                    "--json", "-q")
            runs[folder] = [f["report"]["inet"] for f in json.loads(p.stdout)["frames"]]
        warm, cold = runs["inet_warm"], runs["inet_cold"]
        self.assertEqual([f["warm_start"] for f in warm], [False, True, True, True])
        self.assertFalse(any(f["warm_start"] for f in cold))
        names, meta = grids(self.out("inet_cold", "lit.0002.vdb"))
        self.assertFalse([n for n in names if n.startswith("inet_r")], names)
        self.assertNotIn("vdbscatter_warm_start", meta)
        self.assertIn("inet_r0063", grids(self.out("inet_warm", "lit.0002.vdb"))[0])
        sweeps = [(w["iterations"], c["iterations"]) for w, c in zip(warm, cold)]
        print(f"\ninet sweeps per frame, warm / cold: {sweeps}")
        self.assertEqual(sweeps[0][0], sweeps[0][1])
        for w, c in sweeps[1:]:
            self.assertLess(w, c)
        self.assertLessEqual(sum(w for w, _ in sweeps[1:]), 0.9 * sum(c for _, c in sweeps[1:]))
        for f in range(2, 5):
            a, b = self.out("inet_warm", f"lit.{f:04d}.vdb"), self.out("inet_cold", f"lit.{f:04d}.vdb")
            self.assertEqual(grids(a)[1]["vdbscatter_warm_start"], f"lit.{f - 1:04d}.vdb")
            self.assertLessEqual(ms_rms(a, b), 1e-3, f"frame {f}")

    def test_missing_frames_are_listed(self):
        folder = os.path.join(self.tmp, "missing")
        os.makedirs(folder)
        for f in (1, 2, 4):
            shutil.copy(os.path.join(self.tmp, f"smoke.{f:04d}.vdb"), folder)
        inp = os.path.join(folder, "smoke.%04d.vdb")
        out = os.path.join(folder, "lit.%04d.vdb")
        p = run("bake", inp, "-o", out, *SCENE, "--frames", "1-6", check=2)
        self.assertEqual(len(p.stderr.splitlines()), 1, p.stderr)
        self.assertIn("3 of 6 input frames missing: 3,5-6", p.stderr)
        self.assertFalse([n for n in os.listdir(folder) if n.startswith("lit")])
        p = run("bake", inp, "-o", out, *SCENE, "--frames", "1-6", "--skip-missing", "--json",
                "-q")
        s = json.loads(p.stdout)
        self.assertEqual((s["done"], s["missing"]), (3, 3))
        # frame 4 follows a missing frame: it starts cold
        self.assertFalse(s["frames"][3]["report"]["svd"]["warm_start"])
        self.assertTrue(s["frames"][1]["report"]["svd"]["warm_start"])
        # without --frames: the frames on disk
        p = run("bake", inp, "-o", out, *SCENE, "--json", "-q")
        s = json.loads(p.stdout)
        self.assertEqual((s["frame_list"], s["skipped"]), ("1-2,4", 3))

    def test_a_corrupt_frame_is_a_partial_sequence(self):
        folder = os.path.join(self.tmp, "corrupt")
        os.makedirs(folder)
        for f in (1, 2, 3):
            shutil.copy(os.path.join(self.tmp, f"smoke.{f:04d}.vdb"), folder)
        with open(os.path.join(folder, "smoke.0002.vdb"), "r+b") as f:
            f.truncate(200)
        inp, out = os.path.join(folder, "smoke.####.vdb"), os.path.join(folder, "lit.####.vdb")
        p = run("bake", inp, "-o", out, *SCENE, "--json", check=3)
        s = json.loads(p.stdout)
        self.assertEqual([f["status"] for f in s["frames"]], ["baked", "failed", "baked"])
        self.assertIn("smoke.0002.vdb", p.stderr)
        self.assertFalse(os.path.exists(os.path.join(folder, "lit.0002.vdb")))
        # --verify: one missing, exit 3; after the frame is replaced and baked, 0
        run("bake", inp, "-o", out, *SCENE, "--verify", "-q", check=3)
        shutil.copy(os.path.join(self.tmp, "smoke.0002.vdb"), folder)
        p = run("bake", inp, "-o", out, *SCENE, "--json", "-q")
        self.assertEqual(json.loads(p.stdout)["worked"], 1)
        run("bake", inp, "-o", out, *SCENE, "--verify", "-q")

    def test_bad_words(self):
        out = self.out("bad")
        cases = [
            (["--frames", "5-1"], "runs backwards"),
            (["--frames", "1-3,2"], "listed twice"),
            (["--frames", "x"], "--frames"),
            (["--fps", "0", "--frames", "1"], "--fps"),
        ]
        for extra, needle in cases:
            p = run("bake", self.input, "-o", out, *SCENE, *extra, check=2)
            self.assertIn(needle, p.stderr)
            self.assertEqual(len(p.stderr.splitlines()), 1, p.stderr)
        one = os.path.join(self.tmp, "smoke.0001.vdb")
        for words, needle in [
            (["bake", self.input, "-o", os.path.join(self.tmp, "single.vdb")], "-o:"),
            (["bake", one, "-o", out, "--frames", "1-2"], "frame number in IN"),
            (["bake", os.path.join(self.tmp, "s.####.$F.vdb"), "-o", out], "more than one"),
            (["bake", one, "-o", os.path.join(self.tmp, "x.vdb"), "--verify"], "--verify"),
            (["bake", self.input, "-o", out, "--report", "r.json"], "--report"),
            (["bake", self.input, "-o", out, "--progress", "loud"], "--progress"),
            (["bake", self.input, "-o", out, "--threads", "0"], "--threads"),
            (["bake", one, "-o", os.path.join(self.tmp, "x.vdb"), "--summary",
              os.path.join(self.tmp, "s.json")], "--summary"),
        ]:
            p = run(*words, *SCENE, check=2)
            self.assertIn(needle, p.stderr, words)
            self.assertEqual(len(p.stderr.splitlines()), 1, p.stderr)
        # render's sequence-only flags without a sequence
        lit = self.out("cold", "lit.0001.vdb")
        for flag in (["--fps", "24"], ["--skip-missing"],
                     ["--summary", os.path.join(self.tmp, "s.json")]):
            p = run("render", lit, "-o", os.path.join(self.tmp, "x.png"), *flag, check=2)
            self.assertIn(f"{flag[0]} works on frame sequences", p.stderr)
            self.assertEqual(len(p.stderr.splitlines()), 1, p.stderr)
        for name in ("bad", "single.vdb", "x.vdb", "x.png", "s.json"):
            self.assertFalse(os.path.exists(os.path.join(self.tmp, name)), name)

    def test_render_sequence(self):
        imgs = os.path.join(self.tmp, "img.####.png")
        p = run("render", self.out("cold"), "-o", imgs, "--frames", "1-6x5",
                "--size", "64x48", "--summary", os.path.join(self.tmp, "render.json"), "-q")
        self.assertEqual(p.stderr, "")
        with open(os.path.join(self.tmp, "render.json")) as f:
            s = json.load(f)
        self.assertEqual([(e["frame"], e["status"]) for e in s["frames"]],
                         [(1, "rendered"), (6, "rendered")])
        for f in (1, 6):
            self.assertTrue(os.path.getsize(os.path.join(self.tmp, f"img.{f:04d}.png")) > 0)


if __name__ == "__main__":
    unittest.main()
