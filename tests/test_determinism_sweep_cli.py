#!/usr/bin/python3
"""The bigger determinism sweep (label long; tests/test_determinism_cli.py is the quick one):
every method at medium quality on the cloud under the env map (g 0.85) and on the smoke (sun
and point light, RGB), and POP with the camera's importance, bit-identical grids at 1, 2 and
8 threads on the C path; every method on the GPU path (llvmpipe here) at 1 and 8 threads
(its host-side parts run on OpenMP); and the reference with --tolerance, whose rounds are
sized by the noise so far, at 1 and 8 threads. The GPU path's grids are compared with the GPU
path's only: the twins (tests/test_gl_twins.c) hold the shaders to the C path within 1e-5,
not to the bit."""
import unittest

from test_determinism_cli import METHODS, DeterminismCase, run, sample


class DeterminismSweep(DeterminismCase):
    def test_scenes_medium_across_thread_counts(self):
        scenes = {"cloud_sky": "cloud.vdb", "smoke": "smoke.vdb"}
        for scene, volume in scenes.items():
            for method in METHODS:
                with self.subTest(scene=scene, method=method):
                    runs = self.bake_threads(sample(volume), f"{scene}_{method}",
                                             ["--scene", sample(scene + ".json"), "--method",
                                              method, "--quality", "medium"])
                    self.assert_same_grids(runs, f"{scene} {method} medium")

    def test_pop_importance_across_thread_counts(self):
        runs = self.bake_threads(sample("cloud.vdb"), "importance",
                                 ["--scene", sample("cloud_sky.json"), "--method", "pop",
                                  "--pop-importance"])
        self.assert_same_grids(runs, "pop --pop-importance")

    def test_gpu_path_across_thread_counts(self):
        base = ["--sun", "0.3,-1,0.2", "--env", "0.2,0.25,0.3", "--density-scale", "6",
                "--albedo", "0.9", "--g", "0.5", "--quality", "low", "--backend", "gpu", "-q"]
        for method in METHODS:
            with self.subTest(method=method):
                runs = {}
                for t in (1, 8):
                    out = self.path(f"gpu_{method}_t{t}.vdb")
                    run("bake", sample("sphere.vdb"), "-o", out, *base, "--method", method,
                        threads=t)
                    runs[f"OMP_NUM_THREADS={t}"] = out
                self.assert_same_grids(runs, f"gpu {method}")

    def test_reference_tolerance_across_thread_counts(self):
        images = {}
        for t in (1, 8):
            out = self.path(f"tol_t{t}.exr")
            run("render", sample("cloud.vdb"), "--scene", sample("cloud_sky.json"), "--mode",
                "reference", "--size", "40x30", "--tolerance", "0.2", "--max-bounces", "32",
                "--seed", "3", "-q", "-o", out, threads=t)
            with open(out, "rb") as f:
                images[t] = f.read()
        self.assertEqual(images[8], images[1])

if __name__ == "__main__":
    unittest.main()
