#!/usr/bin/python3
"""Each script of examples/python/ runs (shortened where it takes an end time) and writes its
figure. Usage: examples_test.py SOURCE_DIR (with the module on PYTHONPATH)"""
import os
import subprocess
import sys
import unittest

import matplotlib.image

from scratch import scratch_dir

SOURCE = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else "."


class Examples(unittest.TestCase):
    def run_example(self, script, *args, figure=None):
        """Runs examples/python/SCRIPT with the figure's path (in a scratch folder) first, when
        it takes one; returns (its stdout, the figure's path)."""
        png = os.path.join(scratch_dir(self, "sweep_examples_"), figure) if figure else None
        command = [sys.executable, os.path.join(SOURCE, "examples", "python", script)]
        result = subprocess.run(command + ([png] if png else []) + list(args),
                                capture_output=True, text=True, timeout=300)
        self.assertEqual(result.returncode, 0, result.stderr)
        if png:
            self.assertGreater(os.path.getsize(png), 10000)
        return result.stdout, png

    def test_funnel(self):
        _, png = self.run_example("funnel.py", "0.02", figure="funnel.png")
        image = matplotlib.image.imread(png)
        self.assertGreater(image.shape[1], 1000)
        # the disks are drawn in orange: (1.0, 0.5, 0.05)
        orange = ((abs(image[:, :, 0] - 1.0) < 0.05) & (abs(image[:, :, 1] - 0.5) < 0.05)
                  & (image[:, :, 2] < 0.2))
        self.assertGreater(int(orange.sum()), 2000)

    def test_arm_dynamics(self):
        out, _ = self.run_example("arm_dynamics.py", "0.5", figure="arm.png")
        # semi-implicit Euler at h = 1e-4 keeps the energy to a small fraction over 0.5 s
        drift = float(out.split("end ")[1].split(" J")[0])
        total = float(out.split("of ")[1].split(" J")[0])
        self.assertLess(abs(drift), 1e-2 * max(1.0, abs(total)))

    def test_painleve_rod(self):
        out, _ = self.run_example("painleve_rod.py", "0.02", figure="painleve.png")
        lines = {line.split(":")[0]: line for line in out.splitlines()}
        first = {s: float(lines[s].split("impulse ")[1].split()[0])
                 for s in ("moreau-jean", "catching-up")}
        # Jean-Moreau jams with an impulse of order one (0.3 N s), the staggered scheme takes
        # about the weight's impulse per step (m g h = 9.8e-4 N s) and slides on
        self.assertAlmostEqual(first["moreau-jean"], 0.3, delta=0.01)
        self.assertLess(first["catching-up"], 5 * 9.81e-4)

    def test_kane_impact(self):
        out, _ = self.run_example("kane_impact.py")
        found = {}
        for line in out.splitlines():
            scheme, rest = line.split(": v+ = (")
            v = [float(x) for x in rest.split(")")[0].split(",")]
            gain = float(rest.split("change ")[1].split()[0])
            found[scheme] = (v, gain)
        # the numbers of the solver-level test (tests/integrators/nlgs_test.cpp, KaneImpact)
        (v, gain) = found["moreau-jean"]
        self.assertAlmostEqual(v[0], 1.0, delta=1e-4)
        self.assertAlmostEqual(v[1], -1.02195, delta=1e-4)
        self.assertAlmostEqual(gain, 0.4959, delta=1e-3)
        (v, gain) = found["catching-up"]
        self.assertAlmostEqual(v[0], 1.0, delta=1e-5)
        self.assertAlmostEqual(v[1], 0.0, delta=1e-5)
        self.assertLess(gain, 0.0)

    def test_woodpecker_linearized_model(self):
        out, _ = self.run_example("woodpecker.py", "0.6", figure="woodpecker.png")
        found = {}
        for line in out.splitlines():
            if " pecks, period " not in line:
                continue
            scheme, rest = line.split(": ")
            found[scheme] = (int(rest.split()[0]), float(rest.split("period ")[1].split()[0]),
                             float(rest.split("descent ")[1].split()[0]))
        # Jean-Moreau: the periodic descent of Glocker's model (0.146 s, 0.128 m/s over 1 s)
        pecks, period, descent = found["moreau-jean"]
        self.assertGreaterEqual(pecks, 3)
        self.assertAlmostEqual(period, 0.146, delta=0.005)
        self.assertAlmostEqual(descent, 0.128, delta=0.02)
        # the staggered scheme's frozen thresholds cannot jam the sleeve: it slides (V9)
        self.assertGreater(found["catching-up"][2], 1.0)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
