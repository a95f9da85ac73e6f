#!/usr/bin/python3
"""The lit VDB's bar (docs/lit-vdb.md): `render --mode baked` from the stored optical depths
against `--relight` (light grids swept at render time) within 1% relative RMSE on every
bundled sample, under a sun, a point light, a constant sky and an env map, at g 0, 0.5 and
0.85. Label "heavy": 60 bakes and 120 renders, left out of the ASan pass."""
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_lit_vdb_cli import Base  # noqa: E402

SAMPLES = os.environ["VDBSCATTER_SAMPLES_DIR"]
LIGHTS = {
    "sun": ["--sun", "0.3,-1,0.2:3,2.9,2.7"],
    "point": ["--point", "0.4,1.1,0.5:6,6,6"],
    "sky": ["--env", "0.3,0.4,0.6"],
    "map": ["--env", os.path.join(SAMPLES, "sky.exr")],
}
VOLUMES = ["cloud", "smoke", "sphere", "slab", "cube"]


class Matrix(Base):
    def test_stored_matches_relight(self):
        """Every sample x light x g: from the stored depths against --relight, <= 1%. The
        multiple scattering is read the same way by both (--method single bakes keep the
        matrix fast; test_baked_methods_match_relight covers the solvers)."""
        worst = (0.0, None)
        for volume in VOLUMES:
            for light, flags in LIGHTS.items():
                for g in ("0", "0.5", "0.85"):
                    with self.subTest(volume=volume, light=light, g=g):
                        lit = self.bake(volume, "--method", "single", "--g", g, *flags)
                        j = self.render(lit, "stored.exr")
                        self.assertEqual((j["mode"], j["s1"], j["relight"]), ("baked", "stored", False))
                        self.assertNotIn("light_grids", j)  # nothing swept
                        j = self.render(lit, "relit.exr", "--relight")
                        self.assertEqual((j["s1"], j["relight"]), ("grid", True))
                        e = self.relrmse("stored.exr", "relit.exr")
                        worst = max(worst, (e, (volume, light, g)))
                        self.assertLessEqual(e, 0.01)
        print(f"\nstored against relit, worst relative RMSE {worst[0]:.2e} at {worst[1]}")


if __name__ == "__main__":
    unittest.main(verbosity=2)
