#!/usr/bin/python3
"""`mpiexec -n N sweep run` against `sweep run` (issue #49): the reduced powder bed as a lattice
of 800 equal spheres falling onto the rough plate before the blade comes
(tests/data/ranks_lattice.yaml), on 1, 2 and 3 ranks, and the 2D funnel on 2 and 3. Solved to 1e-10, every rank count ends
within 1e-9 m and 1e-6 m/s (surface speeds of the spins included) of the single process (the
ranks sweep the rows in another order); the statistics summed over the ranks (contacts,
penetration, energy) agree; the same count repeats to the bit; a state saved by the single
process restarts on 2 ranks; snapshots, the layer and the summary are written by rank 0
alone. Adhesive grains, screened candidates and the margin check (the powder bed's fast
setting) agree as well, and so does the staggered scheme. Bad input ends every rank with one
message and exit code 2.
Usage: ranks_test.py SWEEP SOURCE_DIR MPIEXEC"""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

SWEEP = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else "sweep"
SOURCE = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else "."
MPIEXEC = sys.argv[3] if len(sys.argv) > 3 else "mpiexec"
SCENE = os.path.join(SOURCE, "examples/powder_bed/powder_bed_reduced.yaml")
# 200 steps; a snapshot every 100
SETTINGS = ["--set-file", os.path.join(SOURCE, "tests/data/ranks_lattice.yaml"), "--threads", "1",
            "--quiet"]
RADIUS = 20e-6
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMP_NUM_THREADS="1")


def run(ranks, args):
    command = [SWEEP, "run"] + args
    if ranks > 0:
        command = [MPIEXEC, "-n", str(ranks), "--oversubscribe"] + command
    return subprocess.run(command, capture_output=True, text=True, env=ENV, timeout=600)


def read_state(path):
    state = {"t": [], "q": [], "v": []}
    with open(path) as f:
        for row in csv.DictReader(f):
            state[row["vector"]].append(float(row["value"]))
    return state


def read_json(path):
    with open(path) as f:
        return json.load(f)


def read_stats(path):
    with open(path) as f:
        return list(csv.DictReader(f))


class RanksTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="sweep_ranks_")
        cls.single = os.path.join(cls.dir, "single")
        result = run(0, [SCENE, "--out", cls.single] + SETTINGS)
        assert result.returncode == 0, result.stderr

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    def run_single(self, name, extra=()):
        out = os.path.join(self.dir, name)
        result = run(0, [SCENE, "--out", out] + SETTINGS + list(extra))
        self.assertEqual(result.returncode, 0, result.stderr)
        return out

    def run_ranks(self, ranks, name, extra=()):
        out = os.path.join(self.dir, name)
        result = run(ranks, [SCENE, "--out", out] + SETTINGS + list(extra))
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
        return out, result

    def assertClose(self, a, b, q_tolerance, v_tolerance):
        """Centres within q_tolerance, and velocities (linear, and the spins times the radius)
        within v_tolerance; every body a free sphere (q: position, quaternion; v: linear,
        angular)"""
        self.assertEqual(len(a["q"]), len(b["q"]))
        self.assertEqual(a["t"], b["t"])
        bodies = len(a["q"]) // 7
        dx = max(abs(a["q"][7 * i + k] - b["q"][7 * i + k]) for i in range(bodies)
                 for k in range(3))
        dv = max(abs(a["v"][6 * i + k] - b["v"][6 * i + k]) * (1.0 if k < 3 else RADIUS)
                 for i in range(bodies) for k in range(6))
        self.assertLess(dx, q_tolerance)
        self.assertLess(dv, v_tolerance)

    def test_rank_counts_agree_with_the_single_process(self):
        reference = read_state(os.path.join(self.single, "final_state.csv"))
        single_stats = read_stats(os.path.join(self.single, "stats.csv"))
        single_summary = read_json(os.path.join(self.single, "summary.json"))
        for ranks in (1, 2, 3):
            with self.subTest(ranks=ranks):
                out, result = self.run_ranks(ranks, f"ranks{ranks}")
                self.assertClose(read_state(os.path.join(out, "final_state.csv")), reference,
                                 1e-9, 1e-6)
                stats = read_stats(os.path.join(out, "stats.csv"))
                self.assertEqual(len(stats), len(single_stats))
                last, single_last = stats[-1], single_stats[-1]
                # the contacts each rank owns, summed: the single process's, one either way for
                # a gap within round-off of 0 (the ranks detect with the single process's
                # margins)
                for key in ("candidates", "active", "penetration_count"):
                    self.assertLessEqual(abs(int(last[key]) - int(single_last[key])), 1, key)
                for key in ("kinetic", "potential", "penetration_sum"):
                    scale = max(abs(float(single_last[key])), 1e-30)
                    self.assertLess(abs(float(last[key]) - float(single_last[key])) / scale,
                                    1e-4, key)
                summary = read_json(os.path.join(out, "summary.json"))
                self.assertAlmostEqual(summary["energy"]["final"],
                                       single_summary["energy"]["final"], delta=1e-6 *
                                       abs(single_summary["energy"]["final"]))
                if ranks > 1:
                    self.assertEqual(summary["ranks"]["count"], ranks)
                    self.assertGreater(summary["ranks"]["bytes_per_step"], 0)
                    self.assertGreater(float(last["bytes_sent"]), 0)
                    self.assertIn(f"on {ranks} MPI ranks", result.stdout)
                    # rank 0 alone prints: one description, one summary
                    self.assertEqual(result.stdout.count("steps of"), 1)
                else:
                    # one rank runs the single process's step: the same bits
                    self.assertNotIn("ranks", summary)
                    with open(os.path.join(out, "final_state.csv")) as a, \
                            open(os.path.join(self.single, "final_state.csv")) as b:
                        self.assertEqual(a.read(), b.read())
                # the layer and the snapshots, from the gathered state
                layer = read_json(os.path.join(out, "layer.json"))
                single_layer = read_json(os.path.join(self.single, "layer.json"))
                self.assertEqual(layer["particles"], single_layer["particles"])
                self.assertAlmostEqual(layer["height"]["mean"], single_layer["height"]["mean"],
                                       delta=1e-8)
                for name in ("snapshots.pvd", "contacts.pvd"):
                    with open(os.path.join(out, name)) as a, \
                            open(os.path.join(self.single, name)) as b:
                        self.assertEqual(a.read().count("<DataSet"), b.read().count("<DataSet"))
                with open(os.path.join(out, "vtk/snapshot_000002.vtp")) as a, \
                        open(os.path.join(self.single, "vtk/snapshot_000002.vtp")) as b:
                    self.assertEqual(a.read().count("\n"), b.read().count("\n"))
                with open(os.path.join(out, "vtk/contacts_000002.vtp")) as a, \
                        open(os.path.join(self.single, "vtk/contacts_000002.vtp")) as b:
                    verts = lambda text: int(text.split('NumberOfVerts="')[1].split('"')[0])
                    self.assertLessEqual(abs(verts(a.read()) - verts(b.read())), 1)
                self.assertEqual([f for f in os.listdir(out) if f.endswith(".partial")], [])

    def test_same_count_repeats_to_the_bit(self):
        a, _ = self.run_ranks(2, "repeat_a")
        b, _ = self.run_ranks(2, "repeat_b")
        with open(os.path.join(a, "final_state.csv")) as x, \
                open(os.path.join(b, "final_state.csv")) as y:
            self.assertEqual(x.read(), y.read())

    def test_a_saved_state_restarts_on_ranks(self):
        half = self.run_single("half", ["--t-end", "0.001"])
        out, _ = self.run_ranks(2, "restarted", ["--initial-state",
                                                 os.path.join(half, "final_state.csv")])
        self.assertClose(read_state(os.path.join(out, "final_state.csv")),
                         read_state(os.path.join(self.single, "final_state.csv")), 1e-9, 1e-6)
        self.assertEqual(len(read_stats(os.path.join(out, "stats.csv"))), 100)

    def test_adhesive_grains_on_ranks(self):
        """The lattice with a surface energy of 0.1 mJ/m^2 (a pull-off force 9 times a grain's
        weight) over its first 110 steps, as the grains land: the adhesive rows' -h F is part of
        each rank's push, so 2 and 3 ranks end within 1e-9 m and 1e-6 m/s of the adhesive
        single process, which adhesion moves by microns. (Later steps of the adhesive heap
        stall short of 1e-10 at the 5000-sweep cap, and the row orders then part.)"""
        adhesive = ["--set", "generators[0].surface_energy=1e-4", "--set", "time.end=0.0011"]
        single = self.run_single("adhesive_single", adhesive)
        reference = read_state(os.path.join(single, "final_state.csv"))
        cohesionless = self.run_single("cohesionless_110", adhesive[-2:])
        with self.assertRaises(AssertionError):  # adhesion changes the run
            self.assertClose(reference, read_state(os.path.join(cohesionless, "final_state.csv")),
                             1e-7, 1e-4)
        for ranks in (2, 3):
            with self.subTest(ranks=ranks):
                out, _ = self.run_ranks(ranks, f"adhesive{ranks}", adhesive)
                self.assertClose(read_state(os.path.join(out, "final_state.csv")), reference,
                                 1e-9, 1e-6)

    def test_candidate_screening_on_ranks(self):
        """IQS with candidate screening (rows left out beyond 10 nm, admitted when they close)
        over the first 80 steps of the lattice: 2 and 3 ranks repeat the single process's
        screening rounds (one verdict for every rank) and end within 1e-9 m and 1e-6 m/s of it.
        (IQS's heap is sensitive: the single process at 1e-12 against 1e-10 ends microns apart
        after 200 steps; 80 keep the comparison to the solver's tolerance.)"""
        screened = ["--set", "scheme.normal_law=iqs", "--set", "scheme.screening=true", "--set", "scheme.screening_gap=1e-8",
                    "--set", "time.end=0.0008"]
        single = self.run_single("screened_single", screened)
        reference = read_state(os.path.join(single, "final_state.csv"))
        single_stats = read_stats(os.path.join(single, "stats.csv"))
        solves = sum(int(row["solves"]) for row in single_stats)
        self.assertGreater(solves, len(single_stats))  # rounds that admitted candidates
        for ranks in (2, 3):
            with self.subTest(ranks=ranks):
                out, _ = self.run_ranks(ranks, f"screened{ranks}", screened)
                self.assertClose(read_state(os.path.join(out, "final_state.csv")), reference,
                                 1e-9, 1e-6)
                stats = read_stats(os.path.join(out, "stats.csv"))
                self.assertEqual(sum(int(row["solves"]) for row in stats), solves)
                self.assertGreater(sum(int(row["deferred"]) for row in stats), 0)

    def test_the_fast_setting_on_ranks(self):
        """examples/powder_bed/fast.yaml (IQS at h = 1e-4, screening, the relative margin rule
        and the margin check after the solve) over the lattice's first 7 steps, solved to 1e-10:
        the ranks combine their grains' speeds into the single process's margins, so every rank
        count finds the same candidates, detects again on the same steps, repeats as many
        screening rounds, and ends within 1e-9 m and 1e-6 m/s."""
        fast = ["--set-file", os.path.join(SOURCE, "examples/powder_bed/fast.yaml"),
                "--set", "scheme.coulomb.tolerance=1e-10",
                "--set", "scheme.coulomb.residual_check_interval=1",
                "--set", "scheme.coulomb.max_iterations=20000", "--set", "time.end=0.0007"]
        single = self.run_single("fast_single", fast)
        reference = read_state(os.path.join(single, "final_state.csv"))
        single_stats = read_stats(os.path.join(single, "stats.csv"))
        self.assertGreater(sum(int(row["redetections"]) for row in single_stats), 0)
        for ranks in (2, 3):
            with self.subTest(ranks=ranks):
                out, _ = self.run_ranks(ranks, f"fast{ranks}", fast)
                self.assertClose(read_state(os.path.join(out, "final_state.csv")), reference,
                                 1e-9, 1e-6)
                stats = read_stats(os.path.join(out, "stats.csv"))
                for key in ("candidates", "redetections", "solves"):
                    self.assertEqual([row[key] for row in stats],
                                     [row[key] for row in single_stats], key)

    def test_the_2d_funnel_on_ranks(self):
        """500 disks fall into the funnel (200 steps, before the shutter opens), solved to
        1e-10: 2 and 3 ranks end within 1e-9 m and 1e-6 m/s of the single process."""
        funnel = [os.path.join(SOURCE, "examples/funnel/funnel.yaml"), "--scheme", "moreau-jean",
                  "--set", "generators[0].count=500", "--set", "generators[0].orifice=0.0062",
                  "--set", "time.end=0.02", "--set", "scheme.coulomb.tolerance=1e-10",
                  "--set", "scheme.coulomb.max_iterations=5000", "--threads", "1", "--quiet"]
        single = os.path.join(self.dir, "funnel_single")
        result = run(0, funnel + ["--out", single])
        self.assertEqual(result.returncode, 0, result.stderr)
        reference = read_state(os.path.join(single, "final_state.csv"))
        for ranks in (2, 3):
            with self.subTest(ranks=ranks):
                out = os.path.join(self.dir, f"funnel{ranks}")
                result = run(ranks, funnel + ["--out", out])
                self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
                state = read_state(os.path.join(out, "final_state.csv"))
                bodies = len(reference["q"]) // 3  # planar: x, y, angle
                dx = max(abs(state["q"][3 * i + k] - reference["q"][3 * i + k])
                         for i in range(bodies) for k in range(2))
                dv = max(abs(state["v"][3 * i + k] - reference["v"][3 * i + k]) *
                         (1.0 if k < 2 else 0.3e-3) for i in range(bodies) for k in range(3))
                self.assertLess(dx, 1e-9)
                self.assertLess(dv, 1e-6)
                summary = read_json(os.path.join(out, "summary.json"))
                self.assertGreater(summary["ranks"]["shared_bodies_per_step"], 0)

    def test_the_staggered_scheme_on_ranks(self):
        """Scheme B under IQS (stage 5b projects v1 on the closed normals: conjugate gradients
        across the ranks) over the lattice's first 80 steps, both stages solved to 1e-12: 2 and
        3 ranks end within 1e-9 m and 1e-6 m/s of the single process (1e-12 m and 2.4e-8 m/s
        apart on 2 ranks; at 1e-10 the single process with its rows shuffled ends 4e-6 m/s from
        itself, and so do the ranks)."""
        staggered = ["--scheme", "catching-up", "--set", "scheme.normal_law=iqs",
                     "--set", "scheme.normal_stage.tolerance=1e-12",
                     "--set", "scheme.friction_stage.tolerance=1e-12",
                     "--set", "scheme.normal_stage.max_iterations=20000",
                     "--set", "scheme.friction_stage.max_iterations=20000",
                     "--set", "time.end=0.0008"]
        single = self.run_single("staggered_single", staggered)
        reference = read_state(os.path.join(single, "final_state.csv"))
        single_stats = read_stats(os.path.join(single, "stats.csv"))
        self.assertGreater(max(int(row["iterations_stage2"]) for row in single_stats), 0)
        for ranks in (2, 3):
            with self.subTest(ranks=ranks):
                out, _ = self.run_ranks(ranks, f"staggered{ranks}", staggered)
                self.assertClose(read_state(os.path.join(out, "final_state.csv")), reference,
                                 1e-9, 1e-6)
                summary = read_json(os.path.join(out, "summary.json"))
                self.assertGreater(summary["ranks"]["shared_bodies_per_step"], 0)
                stats = read_stats(os.path.join(out, "stats.csv"))
                self.assertGreater(max(int(row["iterations_stage2"]) for row in stats), 0)

    def test_bad_input_ends_every_rank_with_one_message(self):
        cases = [
            # outside the distributed step's scope: a URDF arm
            ([os.path.join(SOURCE, "examples/archetypes/arm_on_table.yaml"), "--set",
              "scheme.projection.max_rounds=0", "--set", "scheme.normal_law=vel"],
             "joint limits"),
            # a field every rank finds wrong
            ([SCENE, "--set", "time.step=-1"], "time.step"),
            # a file that is not there
            ([os.path.join(self.dir, "absent.yaml")], "absent.yaml"),
            # the staggered scheme's stages sweep across the ranks: no MPRGP
            ([SCENE, "--scheme", "catching-up", "--set", "scheme.friction_stage.solver=mprgp"],
             "scheme.friction_stage.solver"),
        ]
        for args, field in cases:
            with self.subTest(field=field):
                result = run(2, args + ["--out", os.path.join(self.dir, "bad"), "--quiet"])
                self.assertEqual(result.returncode, 2, result.stdout + result.stderr)
                self.assertEqual(result.stderr.count("sweep: error:"), 1, result.stderr)
                self.assertIn(field, result.stderr)
        result = subprocess.run([MPIEXEC, "-n", "2", "--oversubscribe", SWEEP, "check", SCENE],
                                capture_output=True, text=True, env=ENV, timeout=120)
        self.assertEqual(result.returncode, 2)
        self.assertEqual(result.stderr.count("only `sweep run` runs on ranks"), 1, result.stderr)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1])
