#!/usr/bin/python3
"""The funnel's study scripts (examples/funnel/scale.py and discharge.py) on scenes small
enough for CI: they run `sweep`, write their tables and plots, and the discharge rates grow
with the orifice. The full studies and their numbers are in docs/funnel.md.
Usage: funnel_studies_test.py SWEEP SOURCE_DIR"""
import csv
import json
import os
import subprocess
import sys
import unittest

from scratch import scratch_dir

SWEEP = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else "build/sweep"
SOURCE = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else "."
EXAMPLE = os.path.join(SOURCE, "examples", "funnel")


def script(name, *args):
    return subprocess.run(["/usr/bin/python3", os.path.join(EXAMPLE, name), "--sweep", SWEEP,
                           *args], capture_output=True, text=True, timeout=600)


class Scale(unittest.TestCase):
    def test_table_plot_and_slope(self):
        out = scratch_dir(self, "sweep_scale_")
        r = script("scale.py", "--out", out, "--counts", "50,200", "--steps", "300",
                   "--schemes", "catching-up,moreau-jean")
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "scale.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([(r["scheme"], r["count"]) for r in rows],
                         [("catching-up", "50"), ("catching-up", "200"), ("moreau-jean", "50"),
                          ("moreau-jean", "200")])
        for row in rows:
            self.assertEqual(int(row["steps"]), 300)
            self.assertGreater(float(row["mean_active"]), 0.0)
        # four times the disks: more contacts and more time per step
        for scheme in ("catching-up", "moreau-jean"):
            small, large = [r for r in rows if r["scheme"] == scheme]
            self.assertGreater(float(large["mean_active"]), 2.0 * float(small["mean_active"]))
            self.assertGreater(float(large["cpu_per_step"]), float(small["cpu_per_step"]))
        with open(os.path.join(out, "slopes.json")) as f:
            slopes = json.load(f)
        self.assertEqual(sorted(slopes), ["catching-up", "moreau-jean"])
        self.assertGreater(os.path.getsize(os.path.join(out, "scale.png")), 10000)


class Discharge(unittest.TestCase):
    def test_rates_grow_with_the_orifice(self):
        out = scratch_dir(self, "sweep_discharge_")
        r = script("discharge.py", "--out", out, "--ratios", "8,12,16", "--count", "300",
                   "--t-end", "0.1", "--shutter", "0.02", "--interval", "0.001", "--",
                   "--set",
                   "scheme.normal_law=pos", "--set", "scheme.tangents=local")
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "discharge.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([float(r["ratio"]) for r in rows], [8.0, 12.0, 16.0])
        rates = [float(r["rate"]) for r in rows]
        self.assertTrue(all(w > 0.0 for w in rates), rates)
        self.assertLess(rates[0], rates[1])
        self.assertLess(rates[1], rates[2])
        # nothing flows before the shutter is pulled: the window starts after it
        self.assertTrue(all(float(r["window_start"]) > 0.02 for r in rows))
        with open(os.path.join(out, "beverloo.json")) as f:
            fit = json.load(f)
        self.assertEqual(fit["rows_used"], 3)
        self.assertIn("exponent", fit)
        self.assertGreater(os.path.getsize(os.path.join(out, "beverloo.png")), 10000)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1])
