#!/usr/bin/python3
"""Threads do not change results: `sweep run` with 1, 2 and 4 threads writes the same
final_state.csv and stats.csv (timing columns aside), bit for bit, on the funnel, a powder bed
and a URDF scene, for both schemes. The coloured sweeps are forced on every island of more
than 16 rows (scheme.coulomb.parallel_rows), and the funnel and the powder reach more than one
block of them (128 rows), so that small scenes exercise the threads.
Usage: threads_test.py SWEEP SOURCE_DIR [CASE] (ctest runs each case as its own test,
app.threads.CASE, so that two run at once)"""
import csv
import hashlib
import json
import os
import subprocess
import sys
import unittest

from scratch import scratch_dir

SWEEP = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else "sweep"
SOURCE = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else "."
ONLY = sys.argv[3] if len(sys.argv) > 3 else None
TIMINGS = {"t_detect", "t_assemble", "t_solve", "t_update"}
# the thread counts compared, the first the reference: ThreadSanitizer's suite compares 2 and 4
# only (scripts/tsan.sh), as a race needs two threads and one thread's run there costs as much
THREAD_COUNTS = [int(t) for t in os.environ.get("SWEEP_TEST_THREAD_COUNTS", "1,2,4").split(",")]
FORCE_COLOURS = ["--set", "scheme.coulomb.parallel_rows=16"]
# scene, its options, and the most active rows it must reach (the arm's few contacts are one
# block of the coloured sweep: it checks that nothing else depends on the thread count)
CASES = {
    "funnel": ("examples/funnel/funnel.yaml",
               ["--set", "generators[0].count=300", "--set", "generators[0].orifice=0.0062",
                "--set", "time.end=0.03"], 129),
    "powder": ("examples/powder_bed/powder_bed_reduced.yaml", ["--set", "time.end=0.006"], 129),
    "urdf_arm": ("examples/archetypes/arm_on_table.yaml", [], 1),
    # 10 000 equal disks on a touching lattice: enough particles and pairs for the threaded
    # broadphase, and 10 000 rows at once, written by the threaded assembly (general rows of
    # planar bodies) and swept with the NNCG momentum's step
    "dense_funnel": ("examples/funnel/funnel.yaml",
                     ["--set", "generators[0].count=10000", "--set",
                      "generators[0].orifice=0.0359", "--set", "generators[0].radius_std=0",
                      "--set", "generators[0].lattice_spacing=1.0", "--set", "time.end=0.001",
                      "--set", "scheme.coulomb.acceleration=nncg"],
                     8192),
    # the same lattice a little apart, under IQS with candidate screening: the threaded
    # screening loops over 10 000 candidates
    "screened_funnel": ("examples/funnel/funnel.yaml",
                        ["--set", "generators[0].count=10000", "--set",
                         "generators[0].orifice=0.0359", "--set", "generators[0].radius_std=0",
                         "--set", "generators[0].lattice_spacing=1.001", "--set",
                         "time.end=0.001", "--set", "scheme.normal_law=iqs", "--set",
                         "scheme.screening=true"],
                        8192),
    # 9600 equal spheres on a touching lattice under the fast powder setting: 29 520 candidate
    # rows, written by the threaded assembly in sphere form
    "powder_lattice": ("examples/powder_bed/powder_bed_reduced.yaml",
                       ["--set", "generators[0].copies_across=12", "--set",
                        "generators[0].lattice_spacing=1.0", "--set",
                        "generators[0].sizes={kind: discrete, diameters: [40e-6], "
                        "mass_fractions: [1]}", "--set-file", os.path.join(SOURCE, "examples/powder_bed/fast.yaml"),
                        "--set", "time.end=0.001"],
                       8192),
}


def run(out, scene, scheme, threads, extra):
    result = subprocess.run(
        [SWEEP, "run", os.path.join(SOURCE, scene), "--out", out, "--quiet", "--threads",
         str(threads), "--scheme", scheme, "--set", "output.vtk_interval=0", *FORCE_COLOURS,
         *extra], capture_output=True, text=True, timeout=600)
    if result.returncode != 0:
        raise AssertionError(result.stderr)
    with open(os.path.join(out, "final_state.csv"), "rb") as f:
        state = hashlib.sha256(f.read()).hexdigest()
    with open(os.path.join(out, "stats.csv")) as f:
        stats = [{k: v for k, v in row.items() if k not in TIMINGS} for row in csv.DictReader(f)]
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return state, stats, summary


class SameBitsForEveryThreadCount(unittest.TestCase):
    def test_cases(self):
        scratch = scratch_dir(self, "sweep_threads_")
        if ONLY is not None and ONLY not in CASES:
            self.fail(f"no case {ONLY}; cases: {', '.join(CASES)}")
        for name, (scene, extra, rows) in CASES.items():
            if ONLY is not None and name != ONLY:
                continue
            for scheme in ("moreau-jean", "catching-up"):
                with self.subTest(case=name, scheme=scheme):
                    results = {}
                    for threads in THREAD_COUNTS:
                        out = os.path.join(scratch, f"{name}_{scheme}_{threads}")
                        results[threads] = run(out, scene, scheme, threads, extra)
                        self.assertEqual(results[threads][2]["threads"], threads)
                    state, stats, _ = results[THREAD_COUNTS[0]]
                    self.assertGreaterEqual(max(int(r["active"]) for r in stats), rows)
                    for threads in THREAD_COUNTS[1:]:
                        self.assertEqual(results[threads][0], state, f"{threads} threads")
                        self.assertEqual(results[threads][1], stats, f"{threads} threads")


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
