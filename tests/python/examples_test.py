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
    def test_funnel(self):
        png = os.path.join(scratch_dir(self, "sweep_examples_"), "funnel.png")
        result = subprocess.run([sys.executable, os.path.join(SOURCE, "examples/python/funnel.py"),
                                 png, "0.02"], capture_output=True, text=True, timeout=300)
        self.assertEqual(result.returncode, 0, result.stderr)
        image = matplotlib.image.imread(png)
        self.assertGreater(image.shape[1], 1000)
        # the disks are drawn in orange: (1.0, 0.5, 0.05)
        orange = ((abs(image[:, :, 0] - 1.0) < 0.05) & (abs(image[:, :, 1] - 0.5) < 0.05)
                  & (image[:, :, 2] < 0.2))
        self.assertGreater(int(orange.sum()), 2000)

    def test_arm_dynamics(self):
        png = os.path.join(scratch_dir(self, "sweep_examples_"), "arm.png")
        result = subprocess.run([sys.executable,
                                 os.path.join(SOURCE, "examples/python/arm_dynamics.py"), png,
                                 "0.5"], capture_output=True, text=True, timeout=300)
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertTrue(os.path.getsize(png) > 10000)
        # semi-implicit Euler at h = 1e-4 keeps the energy to a small fraction over 0.5 s
        drift = float(result.stdout.split("end ")[1].split(" J")[0])
        total = float(result.stdout.split("of ")[1].split(" J")[0])
        self.assertLess(abs(drift), 1e-2 * max(1.0, abs(total)))


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
