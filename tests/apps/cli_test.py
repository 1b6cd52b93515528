#!/usr/bin/python3
"""End-to-end tests of the `sweep` binary: files written by run and bench, exit codes,
messages of the malformed-scene catalogue, --set, --set-file, and Ctrl-C. Usage: cli_test.py SWEEP DATA"""
import csv
import hashlib
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
import unittest
import xml.etree.ElementTree as ET

from scratch import scratch_dir

SWEEP = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else "sweep"
DATA = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else "tests/data"
SCENES = os.path.join(DATA, "scenes")
FUNNEL = os.path.join(os.path.dirname(DATA), "..", "examples", "funnel", "funnel.yaml")
HEADER = ("step,t,candidates,active,islands,iterations_stage1,iterations_stage2,updates,residual,"
          "cap_hit,status,penetration_max,penetration_sum,penetration_count,kinetic,potential,"
          "work_normal,work_tangent,solves,deferred,redetections,t_detect,t_assemble,t_solve,"
          "t_update")


def sweep(*args, cwd=SCENES):
    return subprocess.run([SWEEP, *args], cwd=cwd, capture_output=True, text=True, timeout=600)


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def leftovers(folder):
    return [os.path.join(d, f) for d, _, files in os.walk(folder) for f in files
            if f.endswith(".partial")]


class Run(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = tempfile.mkdtemp(prefix="sweep_run_")
        cls.addClassCleanup(shutil.rmtree, cls.out, ignore_errors=True)
        cls.result = sweep("run", "small_box.yaml", "--out", cls.out, "--quiet")

    def test_exit_code_and_summary_screen(self):
        self.assertEqual(self.result.returncode, 0, self.result.stderr)
        self.assertIn("catching-up: 200 steps", self.result.stdout)
        self.assertIn("detection analytic", self.result.stdout)

    def test_stats_csv(self):
        with open(os.path.join(self.out, "stats.csv")) as f:
            self.assertEqual(f.readline().strip(), HEADER)
        rows = read_csv(os.path.join(self.out, "stats.csv"))
        self.assertEqual(len(rows), 200)
        self.assertEqual([int(r["step"]) for r in rows], list(range(1, 201)))
        self.assertAlmostEqual(float(rows[-1]["t"]), 0.02, places=12)

    def test_summary_agrees_with_stats(self):
        with open(os.path.join(self.out, "summary.json")) as f:
            s = json.load(f)
        rows = read_csv(os.path.join(self.out, "stats.csv"))
        for key in ("scheme", "dt", "t_end", "steps", "cpu_seconds", "wall_seconds",
                    "penetration", "iterations", "contacts", "energy"):
            self.assertIn(key, s)
        self.assertEqual(s["scheme"], "catching-up")
        self.assertEqual(s["steps"], len(rows))
        self.assertFalse(s["interrupted"])
        pen = sum(float(r["penetration_sum"]) for r in rows)
        self.assertAlmostEqual(s["penetration"]["cumulative"], pen, delta=1e-12 * max(pen, 1e-30))
        self.assertAlmostEqual(s["penetration"]["peak"], max(float(r["penetration_max"]) for r in rows))
        overlapping = sum(int(r["penetration_count"]) for r in rows)
        self.assertGreater(overlapping, 0)
        self.assertAlmostEqual(s["penetration"]["mean_per_contact"], pen / overlapping,
                               delta=1e-12 * pen / overlapping)
        size = s["penetration"]["smallest_size"]
        self.assertGreater(size, 0)
        self.assertAlmostEqual(s["penetration"]["peak_of_smallest_size"],
                               s["penetration"]["peak"] / size)
        totals = [int(r["iterations_stage1"]) + int(r["iterations_stage2"]) for r in rows]
        self.assertEqual(s["iterations"]["max"], max(totals))
        self.assertAlmostEqual(s["iterations"]["mean"], sum(totals) / len(totals))
        self.assertEqual(s["iterations"]["cap_hit_steps"], sum(int(r["cap_hit"]) for r in rows))
        self.assertEqual(s["contacts"]["max_active"], max(int(r["active"]) for r in rows))
        final = float(rows[-1]["kinetic"]) + float(rows[-1]["potential"])
        self.assertAlmostEqual(s["energy"]["final"], final, delta=1e-9 * abs(final))

    def test_vtk_series(self):
        pvd = ET.parse(os.path.join(self.out, "snapshots.pvd")).getroot()
        datasets = pvd.findall("./Collection/DataSet")
        self.assertEqual(len(datasets), 1 + 200 // 50)
        for k, d in enumerate(datasets):
            piece = ET.parse(os.path.join(self.out, d.get("file"))).getroot().find("./PolyData/Piece")
            n = int(piece.get("NumberOfPoints"))
            # 24 disks, the paddle's two end points until it is removed at t = 0.015, and the
            # two ends of each of the three half-planes' segments
            paddle = 2 if float(d.get("timestep")) < 0.015 else 0
            self.assertEqual(n, 24 + paddle + 3 * 2, d.get("file"))
            points = piece.find("./Points/DataArray").text.split()
            self.assertEqual(len(points), 3 * n)
            names = {a.get("Name") for a in piece.findall("./PointData/DataArray")}
            self.assertTrue({"body_id", "radius", "velocity", "contact_force"} <= names)
            for a in piece.findall("./PointData/DataArray"):
                width = int(a.get("NumberOfComponents", "1"))
                self.assertEqual(len(a.text.split()), width * n, a.get("Name"))

    def test_no_partial_files(self):
        self.assertEqual(leftovers(self.out), [])


@unittest.skipUnless(os.path.exists("/dev/full"), "needs /dev/full")
class FullDisk(unittest.TestCase):
    """A full disk is an error, not a silently short file: each output's temporary name is
    pointed at /dev/full (every write fails with ENOSPC) before the run."""

    def run_with_full(self, name, steps):
        out = scratch_dir(self, "sweep_full_")
        os.symlink("/dev/full", os.path.join(out, name + ".partial"))
        r = sweep("run", "small_box.yaml", "--out", out, "--quiet",
                  "--set", f"time.end={steps * 1e-4}")
        return out, r

    def test_stats_on_a_full_disk(self):
        out, r = self.run_with_full("stats.csv", 3000)  # fails at its first check, step 1024
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn("stats.csv.partial: cannot write at step 1024 (disk full?)", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(out, "stats.csv")))
        self.assertFalse(os.path.exists(os.path.join(out, "summary.json")))

    def test_summary_on_a_full_disk(self):
        out, r = self.run_with_full("summary.json", 20)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn("summary.json.partial: cannot write (disk full?)", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(out, "summary.json")))
        # nor does the temporary stay behind
        self.assertFalse(os.path.lexists(os.path.join(out, "summary.json.partial")))


class Inputs(unittest.TestCase):
    def test_every_malformed_scene_exits_2_with_its_message(self):
        bad = sorted(os.listdir(os.path.join(SCENES, "bad")))
        self.assertGreaterEqual(len(bad), 20)
        for name in bad:
            with open(os.path.join(SCENES, "bad", name)) as f:
                expected = f.readline()[len("# expect: "):].rstrip("\n")
            r = sweep("check", os.path.join("bad", name))
            self.assertEqual(r.returncode, 2, name)
            self.assertEqual(r.stderr.strip(), "sweep: error: " + expected, name)

    def test_missing_file(self):
        r = sweep("run", "no_such_scene.yaml")
        self.assertEqual(r.returncode, 2)
        self.assertIn("no_such_scene.yaml: cannot open the file", r.stderr)

    def test_bad_command_line(self):
        self.assertEqual(sweep("run", "small_box.yaml", "--dt", "-1").returncode, 2)
        self.assertEqual(sweep("run", "small_box.yaml", "--scheme", "euler").returncode, 2)
        self.assertEqual(sweep("frobnicate").returncode, 2)
        r = sweep("run", "small_box.yaml", "--set", "time.stepp=1")
        self.assertEqual(r.returncode, 2)
        self.assertIn("time.stepp: unknown key", r.stderr)
        # a value is one YAML document: a second one is refused, not dropped
        r = sweep("run", "small_box.yaml", "--set", "time.end=0.01\n---\n5", "--quiet")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("--set time.end=0.01\n---\n5: a second YAML document, or text outside "
                      "the first, starts at character 6 of the value; a value is one document",
                      r.stderr)
        # every negative count is refused, -1 too (once the "not given" mark)
        for command in (["run"], ["bench", "--dt", "1e-3"]):
            for count in ("-1", "-2", "1025"):
                r = sweep(command[0], "small_box.yaml", *command[1:], "--threads", count,
                          "--quiet")
                self.assertEqual(r.returncode, 2, (command, count, r.stderr))
                self.assertIn(f"--threads: must be in [0, 1024] (0: every core), got {count}",
                              r.stderr)

    def test_several_mpi_processes_are_refused_before_any_output(self):
        out = tempfile.mkdtemp(prefix="sweep_ranks_")
        self.addCleanup(shutil.rmtree, out, ignore_errors=True)
        for name in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE"):
            env = dict(os.environ, **{name: "4"})
            r = subprocess.run([SWEEP, "run", "small_box.yaml", "--out", out, "--quiet"],
                               cwd=SCENES, capture_output=True, text=True, timeout=600, env=env)
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn(f"started as one of 4 MPI processes ({name}=4)", r.stderr)
            self.assertEqual(os.listdir(out), [])
        # one process under a launcher runs as usual
        env = dict(os.environ, OMPI_COMM_WORLD_SIZE="1")
        r = subprocess.run([SWEEP, "run", "small_box.yaml", "--out", out, "--quiet",
                            "--t-end", "0.002"], cwd=SCENES, capture_output=True, text=True,
                           timeout=600, env=env)
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_set_and_options_override_the_scene(self):
        out = scratch_dir(self, "sweep_set_")
        r = sweep("run", "small_box.yaml", "--out", out, "--quiet", "--set", "time.end=0.005",
                  "--scheme", "moreau-jean", "--dt", "2.5e-4")
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(out, "summary.json")) as f:
            s = json.load(f)
        self.assertEqual(s["scheme"], "moreau-jean")
        self.assertEqual(s["steps"], 20)

    def test_settings_file_overrides_the_scene_and_set_wins(self):
        r = sweep("check", "small_box.yaml", "--set-file", "settings/small_box_fine.yaml")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("h = 5e-05 s", r.stdout)
        self.assertIn("normal law pos", r.stdout)
        self.assertIn("10 with a constant mass block", r.stdout)
        r = sweep("check", "small_box.yaml", "--set-file", "settings/small_box_fine.yaml",
                  "--set", "time.step=2e-5")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("h = 2e-05 s", r.stdout)
        r = sweep("run", "small_box.yaml", "--set-file", "settings/none.yaml")
        self.assertEqual(r.returncode, 2)
        self.assertIn("settings/none.yaml: cannot open the file", r.stderr)
        r = sweep("run", "small_box.yaml", "--set-file", "settings/bad/through_a_number.yaml")
        self.assertEqual(r.returncode, 2)
        self.assertIn("settings/bad/through_a_number.yaml: time.step.value:", r.stderr)

    def test_without_timings_stats_are_bitwise_reproducible(self):
        """stats.csv and the final state (final_state.csv: q and v at 17 digits) hash the
        same in two runs."""
        digests, states = [], []
        for _ in range(2):
            out = scratch_dir(self, "sweep_repeat_")
            r = sweep("run", "small_box.yaml", "--out", out, "--quiet", "--set",
                      "output.timings=false", "--set", "time.end=0.01")
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(os.path.join(out, "stats.csv"), "rb") as f:
                data = f.read()
            digests.append(hashlib.sha256(data).hexdigest())
            with open(os.path.join(out, "final_state.csv"), "rb") as f:
                state = f.read()
            states.append(hashlib.sha256(state).hexdigest())
        self.assertEqual(len(state.decode().splitlines()), 1 + 1 + 72 + 72)
        self.assertEqual(states[0], states[1])
        header = data.decode().splitlines()[0]
        self.assertEqual(header, HEADER.rsplit(",t_detect", 1)[0])
        self.assertEqual(len(data.decode().splitlines()), 101)
        self.assertEqual(digests[0], digests[1])

    def test_check_describes_without_running(self):
        r = sweep("check", "small_box.yaml")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("scene is valid", r.stdout)
        self.assertIn("24 with a constant mass block", r.stdout)


ONE_DISK = """dimension: 2
gravity: [0, -9.81]
bodies:
  - {name: floor, shape: half_plane, position: [0, 0], normal: NORMAL, fixed: true}
  - {name: d, shape: disk, radius: 0.01, mass: 1, inertia: 5.0e-5, position: [0, 0.0105]}
time: {step: 1.0e-3, end: 0.05}
"""


class Hostile(unittest.TestCase):
    """Inputs unlike the catalogue (issue #31): each ends in exit 2 with a message naming the
    file, field and value, or in a clean run; never a signal, a hang or a runaway allocation."""

    def scene(self, text, name="scene.yaml"):
        folder = scratch_dir(self, "sweep_hostile_")
        path = os.path.join(folder, name)
        with open(path, "w") as f:
            f.write(text)
        return folder, path

    def test_time_windows_that_give_no_step_or_too_many(self):
        folder, path = self.scene(ONE_DISK.replace("NORMAL", "[0, 1]"))
        # what run refuses at load, check refuses with the same words
        for command in (["check"], ["run", "--out", os.path.join(folder, "long"), "--quiet"]):
            r = sweep(command[0], path, *command[1:], "--set", "time.step=2",
                      "--set", "time.end=10")
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn("scene.yaml: time.step = 2 s is longer than 1 s", r.stderr)
        for options, message in [
            (["--t-end", "1e-4"], "scene.yaml: time.end = 1e-04 s with time.step = 0.001 s: "
                                  "the end comes before the first step does"),
            (["--dt", "1e-15", "--t-end", "1e300"],
             "scene.yaml: time.end = 1e+300 s with time.step = 1e-15 s is more than 1e308 steps, "
             "more than the 2e+09 a run may take"),
            (["--dt", "1e-12", "--t-end", "1"],
             "time.end = 1 s with time.step = 1e-12 s is 1e+12 steps, more than the 2e+09"),
            (["--dt", "-0"], "--dt: must be > 0, got -0"),
        ]:
            r = sweep("run", path, "--out", os.path.join(folder, "out"), "--quiet", *options)
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn(message, r.stderr)
            self.assertFalse(os.path.exists(os.path.join(folder, "out", "summary.json")))

    def test_bad_balance_options_are_refused(self):
        if "--rebalance-every" not in sweep("run", "--help").stdout:
            self.skipTest("a build without MPI has no balance options")
        folder = scratch_dir(self, "sweep_balance_")
        for options, message in [
            (["--rebalance-every", "-1"], "--rebalance-every: must be a finite number >= 0, got -1"),
            (["--rebalance-above", "nan"], "--rebalance-above: must be a finite number >= 0, got nan"),
            (["--rebalance-above", "-0.5"], "--rebalance-above: must be a finite number >= 0, got -0.5"),
        ]:
            r = sweep("run", "small_box.yaml", "--out", os.path.join(folder, "out"), "--quiet",
                      *options)
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn(message, r.stderr)
            self.assertFalse(os.path.exists(os.path.join(folder, "out", "summary.json")))

    def test_empty_or_folder_outputs_are_refused(self):
        for command in (["run", "small_box.yaml"], ["bench", "small_box.yaml", "--dt", "1e-3"]):
            r = sweep(*command, "--out", "", "--quiet")
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn("--out: must name a folder, got ''", r.stderr)
        r = sweep("export", "small_box.yaml", "")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("export: OUTPUT must name a file, got ''", r.stderr)
        folder = scratch_dir(self, "sweep_export_")
        r = sweep("export", "small_box.yaml", folder)
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn(folder + ": is a folder; export writes a scene file", r.stderr)

    def test_outputs_that_are_not_regular_files_are_refused_before_the_first_step(self):
        folder = scratch_dir(self, "sweep_outputs_")
        fifo = os.path.join(folder, "scene.fifo")
        os.mkfifo(fifo)
        for args in (["export", "small_box.yaml", fifo],
                     ["export", "small_box.yaml", os.path.join(folder, "null")]):
            if args[-1].endswith("null"):
                os.symlink("/dev/null", args[-1])
            r = sweep(*args)
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn(args[-1] + ": exists and is not a regular file", r.stderr)
        self.assertTrue(stat.S_ISFIFO(os.stat(fifo).st_mode))
        # a folder where a run's file goes: refused before any step, nothing else written
        out = os.path.join(folder, "run")
        os.makedirs(os.path.join(out, "summary.json"))
        r = sweep("run", "small_box.yaml", "--out", out, "--quiet")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn(os.path.join(out, "summary.json") + ": exists and is not a regular file "
                      "(a folder)", r.stderr)
        self.assertEqual(sorted(os.listdir(out)), ["summary.json"])

    def test_a_run_whose_state_runs_away_fails_with_whole_outputs(self):
        out = scratch_dir(self, "sweep_runaway_")
        r = sweep("run", "runaway.yaml", "--out", out, "--quiet")
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn("step 1 (t = 0.001 s): body 'ball' has run away", r.stderr)
        self.assertIn("(RAN AWAY)", r.stdout)
        self.assertEqual(leftovers(out), [])
        with open(os.path.join(out, "summary.json")) as f:
            summary = json.load(f)
        self.assertIn("has run away", summary["failure"])
        self.assertEqual(summary["steps"], 0)
        self.assertEqual(read_csv(os.path.join(out, "stats.csv")), [])
        # the state it ran away to, at the end of step 1 (5e8 m/s^2 for 1 ms: 5e5 m/s)
        state = read_csv(os.path.join(out, "final_state.csv"))
        self.assertEqual(float(state[0]["value"]), 0.001)
        # a run of the same scene within bounds (a thousandth of the force) succeeds
        ok = sweep("run", "runaway.yaml", "--out", out, "--quiet",
                   "--set", "loads[0].force=[0, 1e6, 0]")
        self.assertEqual(ok.returncode, 0, ok.stdout + ok.stderr)

    def test_a_report_that_cannot_be_written_is_a_failure(self):
        if not os.path.exists("/dev/full"):
            self.skipTest("no /dev/full")
        with open("/dev/full", "w") as full:
            r = subprocess.run([SWEEP, "check", "small_box.yaml"], cwd=SCENES, stdout=full,
                               stderr=subprocess.PIPE, text=True, timeout=600)
        self.assertEqual(r.returncode, 1, r.stderr)
        self.assertIn("cannot write to standard output", r.stderr)

    def test_snapshot_interval_far_below_the_step_writes_one_per_step(self):
        text = ONE_DISK.replace("NORMAL", "[0, 1]") + "output: {vtk_interval: 1.0e-30}\n"
        folder, path = self.scene(text)
        r = subprocess.run([SWEEP, "run", path, "--out", os.path.join(folder, "out"), "--quiet"],
                           capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)
        vtk = [f for f in os.listdir(os.path.join(folder, "out", "vtk"))
               if f.startswith("snapshot_") and f.endswith(".vtp")]
        self.assertEqual(len(vtk), 51)  # the initial state and one per step
        contacts = [f for f in os.listdir(os.path.join(folder, "out", "vtk"))
                    if f.startswith("contacts_") and f.endswith(".vtp")]
        self.assertEqual(len(contacts), 51)  # a contact network beside each

    def test_a_huge_normal_is_the_same_wall(self):
        finals = []
        for normal in ("[0, 1]", "[0, 1.0e200]", "[0, 1.0e-200]"):
            folder, path = self.scene(ONE_DISK.replace("NORMAL", normal))
            r = sweep("run", path, "--out", os.path.join(folder, "out"), "--quiet")
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(os.path.join(folder, "out", "final_state.csv")) as f:
                finals.append(f.read())
        self.assertEqual(finals[1], finals[0])
        self.assertEqual(finals[2], finals[0])

    def test_a_scene_larger_than_memory_is_refused_before_allocation(self):
        import resource
        text = ("dimension: 2\ngenerators:\n  - {type: disks, count: 1000000, radius: {mean: 1.0e-3, "
                "std: 0}, region: {min: [0, 0], max: [3, 3]}, spacing: 1.2, mass: 1}\n")
        text = text.replace(", mass: 1}", "}")
        folder, path = self.scene(text)
        limit = 1 << 30

        def cap():
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

        r = subprocess.run([SWEEP, "check", path], capture_output=True, text=True, timeout=60,
                           preexec_fn=cap)
        if "Sanitizer" in r.stderr:
            self.skipTest("a sanitized build cannot start within 1 GiB of address space")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("scene.yaml: generators[0].count = 1000000 (1000000 bodies in the scene "
                      "so far) needs about 5 GB of memory, more than the 1.07 GB this process "
                      "may use (the address-space limit, ulimit -v)", r.stderr)

    def test_summary_json_is_json(self):
        folder, path = self.scene(ONE_DISK.replace("NORMAL", "[0, 1]"))
        r = sweep("run", path, "--out", os.path.join(folder, "out"), "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(folder, "out", "summary.json")) as f:
            summary = json.load(f, parse_constant=lambda c: self.fail("not JSON: " + c))
        self.assertEqual(summary["steps"], 50)


class Restart(unittest.TestCase):
    """--initial-state: a run continues from another run's final_state.csv (its t, q, v)."""

    def run_to(self, t_end, *extra):
        out = scratch_dir(self, "sweep_restart_")
        r = sweep("run", "loads_3d.yaml", "--out", out, "--quiet", "--t-end", str(t_end), *extra)
        self.assertEqual(r.returncode, 0, r.stderr)
        return out, r

    def test_driven_bodies_are_where_the_saved_time_puts_them(self):
        """The funnel's shutter is pulled at 0.03 s and disks fall through where it was: a
        state saved at 0.04 s overlaps the shutter's place at t = 0, not at 0.04 s."""
        funnel = os.path.join(os.path.dirname(DATA), "..", "examples", "funnel", "funnel.yaml")
        first = scratch_dir(self, "sweep_restart_")
        r = sweep("run", funnel, "--out", first, "--quiet", "--t-end", "0.04",
                  "--set", "output.vtk_interval=0")
        self.assertEqual(r.returncode, 0, r.stderr)
        second = scratch_dir(self, "sweep_restart_")
        r = sweep("run", funnel, "--out", second, "--quiet", "--t-end", "0.045",
                  "--set", "output.vtk_interval=0",
                  "--initial-state", os.path.join(first, "final_state.csv"))
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_two_halves_end_where_one_run_ends(self):
        """No contacts, so no warm start is lost: the halves give the same bits. The torque
        ramps with t, so a restart that forgot the saved time would end elsewhere."""
        whole, _ = self.run_to(0.5)
        half, _ = self.run_to(0.25)
        second, r = self.run_to(0.5, "--initial-state", os.path.join(half, "final_state.csv"))
        self.assertIn("starting from", r.stdout)
        with open(os.path.join(whole, "final_state.csv")) as f:
            expected = f.read()
        with open(os.path.join(second, "final_state.csv")) as f:
            got = f.read()
        self.assertTrue(expected.startswith("vector,index,value\nt,0,0.5"), expected[:60])
        self.assertEqual(got, expected)
        rows = read_csv(os.path.join(second, "stats.csv"))
        self.assertEqual(len(rows), 250)
        self.assertAlmostEqual(float(rows[0]["t"]), 0.251, places=12)
        # and from t = 0 instead the same 250 steps end elsewhere
        with open(os.path.join(half, "final_state.csv")) as f:
            no_time = "".join(l for l in f if not l.startswith("t,"))
        state = os.path.join(scratch_dir(self, "sweep_restart_"), "state.csv")
        with open(state, "w") as f:
            f.write(no_time.replace("vector,index,value\n", "vector,index,value\nt,0,0\n"))
        third, _ = self.run_to(0.25, "--initial-state", state)
        with open(os.path.join(third, "final_state.csv")) as f:
            self.assertNotEqual(f.read().split("\n", 2)[2], expected.split("\n", 2)[2])

    def test_bad_saved_states_exit_2_naming_file_line_and_value(self):
        half, _ = self.run_to(0.25)
        with open(os.path.join(half, "final_state.csv")) as f:
            good = f.read().splitlines()
        folder = scratch_dir(self, "sweep_restart_bad_")
        cases = {
            "missing.csv": (None, "saved state does not exist"),
            "header.csv": (["q,0,1"] + good[1:], "header"),
            "nan.csv": (good[:3] + ["q,1,nan"] + good[4:], "q[1] = nan is not finite"),
            "range.csv": (good + ["v,6,0"], "v index 6 is out of range [0, 6)"),
            "short.csv": (good[:-1], "v[5] is missing"),
            "twice.csv": (good + ["q,0,1"], "q[0] is given twice"),
            "kind.csv": (good + ["w,0,1"], "vector 'w' is none of t, q, v"),
            "text.csv": (good[:2] + ["q,0,abc"] + good[3:], "value 'abc' is not a number"),
            "cut.csv": (good[:2] + ["q,0"] + good[3:], "expected 'vector,index,value', got 'q,0'"),
            "before.csv": ([good[0], "t,0,-1e300"] + good[2:],
                           "t = -1e+300 s is before the scene's start (t = 0)"),
            "far.csv": (good[:2] + ["q,0,1e300"] + good[3:],
                        "q[0] = 1e+300 (body 'ball') is beyond 1e+06 (m or rad)"),
            "quaternion.csv": (good[:5] + ["q,3,0", "q,4,0", "q,5,0", "q,6,0"] + good[9:],
                               "q[3..6] (body 'ball'): the orientation quaternion has norm 0, "
                               "not 1"),
            "no_time.csv": ([good[0]] + good[2:], "no 't' row"),
        }
        for name, (lines, message) in cases.items():
            path = os.path.join(folder, name)
            if lines is not None:
                with open(path, "w") as f:
                    f.write("\n".join(lines) + "\n")
            out = os.path.join(folder, "out_" + name)
            r = sweep("run", "loads_3d.yaml", "--out", out, "--quiet", "--initial-state", path)
            self.assertEqual(r.returncode, 2, name + ": " + r.stderr)
            self.assertIn(path, r.stderr, name)
            self.assertIn(message, r.stderr, name)
            self.assertFalse(os.path.exists(os.path.join(out, "summary.json")), name)
        # a subnormal number, which a run may write, reads back
        path = os.path.join(folder, "subnormal.csv")
        with open(path, "w") as f:
            f.write("\n".join(good[:9] + ["v,0,1e-310"] + good[10:]) + "\n")
        r = sweep("run", "loads_3d.yaml", "--out", os.path.join(folder, "out_subnormal"),
                  "--quiet", "--initial-state", path)
        self.assertEqual(r.returncode, 0, r.stderr)
        # a state at or after t_end leaves nothing to run
        r = sweep("run", "loads_3d.yaml", "--quiet", "--out", os.path.join(folder, "late"),
                  "--t-end", "0.2", "--initial-state", os.path.join(half, "final_state.csv"))
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("leaves no step after the saved state's t = 0.25", r.stderr)


TILE_STATE = os.path.join(os.path.dirname(os.path.dirname(DATA)), "scripts", "tile_state.py")
SMALL_BED = """dimension: 3
gravity: [0, -9.81, 0]
generators:
  - {type: powder_bed, count: 60, width: 0.2e-3, length: 1.5e-3, travel: 0.5e-3,
     heap_length: 0.3e-3, settle_time: 0.02}
scheme: {name: moreau-jean, normal_law: vel}
time: {step: 1e-5, end: 0.008}
output: {layer: {x_min: 0.2e-3, x_max: 1.0e-3}}
"""


class TiledBed(unittest.TestCase):
    """scripts/tile_state.py: a state of a one-copy powder bed, tiled, starts the bed of
    copies_across: 2, which then moves as two copies of the one-copy bed."""

    def test_two_copies_move_as_the_one_copy_bed(self):
        folder = scratch_dir(self, "sweep_tile_")
        scene = os.path.join(folder, "bed.yaml")
        with open(scene, "w") as f:
            f.write(SMALL_BED)
        settled = os.path.join(folder, "settled")
        r = sweep("run", scene, "--out", settled, "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        # the height map (libpng) is the window's columns, coloured where the layer covers
        import matplotlib.image
        with open(os.path.join(settled, "layer.json")) as f:
            layer = json.load(f)
        window = layer["window"]
        image = matplotlib.image.imread(os.path.join(settled, "layer_height.png"))
        self.assertEqual(image.shape, (round((window["z_max"] - window["z_min"]) / window["resolution"]),
                                       round((window["x_max"] - window["x_min"]) / window["resolution"]), 3))
        covered = (image.max(axis=2) > 0).mean()
        self.assertAlmostEqual(covered, layer["coverage"], places=9)
        state = os.path.join(settled, "final_state.csv")
        tiled = os.path.join(folder, "tiled.csv")
        r = subprocess.run(["/usr/bin/python3", TILE_STATE, state, "--copies", "2", "--width",
                            "0.2e-3", "--out", tiled], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stderr)
        runs = {}
        for copies in (1, 2):
            out = os.path.join(folder, f"copies{copies}")
            r = sweep("run", scene, "--out", out, "--quiet", "--t-end", "0.0081",
                      "--initial-state", state if copies == 1 else tiled,
                      "--set", f"generators[0].copies_across={copies}")
            self.assertEqual(r.returncode, 0, r.stderr)
            rows = read_csv(os.path.join(out, "stats.csv"))
            with open(os.path.join(out, "final_state.csv")) as f:
                q = [float(l.split(",")[2]) for l in f if l.startswith("q,")]
            runs[copies] = (rows, q)
        (rows1, q1), (rows2, q2) = runs[1], runs[2]
        self.assertEqual(len(rows1), 10)
        # every pair of the one-copy bed, those through its periodic boundary included, is
        # two pairs of the two-copy bed on the first step
        self.assertGreater(int(rows1[0]["active"]), 20)
        self.assertEqual(int(rows2[0]["active"]), 2 * int(rows1[0]["active"]))
        self.assertEqual(len(q2), 2 * len(q1))
        worst = 0.0
        for copy in (0, 1):
            for i, value in enumerate(q1):
                shift = copy * 0.2e-3 if i % 7 == 2 else 0.0
                if i % 7 < 3:
                    worst = max(worst, abs(q2[copy * len(q1) + i] - value - shift))
        self.assertLess(worst, 1e-9)  # m; in 10 steps the grains move 3e-6

    def test_bad_input_exits_2_naming_it(self):
        folder = scratch_dir(self, "sweep_tile_bad_")
        missing = os.path.join(folder, "missing.csv")
        cases = [([missing, "--copies", "2", "--width", "1"], missing),
                 ([missing, "--copies", "0", "--width", "1"], "--copies 0 must be >= 1"),
                 ([missing, "--copies", "2", "--width", "nan"], "--width nan must be > 0")]
        odd = os.path.join(folder, "odd.csv")
        with open(odd, "w") as f:
            f.write("vector,index,value\nt,0,0\n" + "".join(f"q,{i},0\n" for i in range(7)) +
                    "".join(f"v,{i},0\n" for i in range(5)))
        cases.append(([odd, "--copies", "2", "--width", "1"], "nq = 7, nv = 5"))
        for args, message in cases:
            out = os.path.join(folder, "out.csv")
            r = subprocess.run(["/usr/bin/python3", TILE_STATE, *args, "--out", out],
                               capture_output=True, text=True)
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn(message, r.stderr)
            self.assertFalse(os.path.exists(out))


def wait_for_handlers(process, timeout=60.0):
    """Waits until the process catches SIGTERM (its handlers are installed, /proc/PID/status
    SigCgt): a signal sent before would end it by the default action, not by Sweep's."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and process.poll() is None:
        with open(f"/proc/{process.pid}/status") as f:
            caught = next((line.split()[1] for line in f if line.startswith("SigCgt:")), "0")
        if int(caught, 16) & (1 << (signal.SIGTERM - 1)):
            return
        time.sleep(0.01)
    raise AssertionError("the process never installed its signal handlers")


class Interrupt(unittest.TestCase):
    def test_ctrl_c_sigterm_and_sighup_leave_valid_flagged_results(self):
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            out = scratch_dir(self, "sweep_int_")
            p = subprocess.Popen([SWEEP, "run", "small_box.yaml", "--out", out, "--quiet",
                                  "--set", "time.end=1000"], cwd=SCENES,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            wait_for_handlers(p)
            time.sleep(1.5)
            p.send_signal(sig)
            stdout, stderr = p.communicate(timeout=60)
            self.assertEqual(p.returncode, 128 + sig, f"{sig}: {stderr}")
            with open(os.path.join(out, "summary.json")) as f:
                s = json.load(f)
            self.assertTrue(s["interrupted"])
            rows = read_csv(os.path.join(out, "stats.csv"))
            self.assertEqual(len(rows), s["steps"])
            self.assertGreater(s["steps"], 0)
            self.assertEqual(leftovers(out), [])


    def test_a_step_that_does_not_end_is_stopped_within_about_a_second(self):
        # a sweep cap of 10^8 at an unreachable tolerance: the first contact step lasts minutes
        out = scratch_dir(self, "sweep_int_")
        p = subprocess.Popen([SWEEP, "run", FUNNEL, "--out", out, "--quiet", "--scheme",
                              "moreau-jean", "--set", "scheme.coulomb.max_iterations=100000000",
                              "--set", "scheme.coulomb.tolerance=1e-300"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wait_for_handlers(p)
        time.sleep(2.0)
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        p.communicate(timeout=60)
        self.assertEqual(p.returncode, 130)
        self.assertLess(time.monotonic() - sent, 5.0)
        self.assertFalse(os.path.exists(os.path.join(out, "stats.csv")))
        self.assertEqual(leftovers(out), [])

    def test_check_stops_on_a_signal_while_it_builds(self):
        # 10^5 disks: about 2 s of building, which no loop polls
        p = subprocess.Popen([SWEEP, "check", FUNNEL, "--set", "generators[0].count=100000",
                              "--set", "generators[0].orifice=0.1"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wait_for_handlers(p)
        time.sleep(0.3)
        sent = time.monotonic()
        p.send_signal(signal.SIGTERM)
        stdout, _ = p.communicate(timeout=60)
        self.assertEqual(p.returncode, 143)
        self.assertLess(time.monotonic() - sent, 1.5)
        self.assertNotIn("scene is valid", stdout)


class Bench(unittest.TestCase):
    def test_bench_writes_table_and_figures(self):
        out = scratch_dir(self, "sweep_bench_")
        r = sweep("bench", "small_box.yaml", "--dt", "2e-4,1e-4", "--t-end", "0.004",
                  "--out", out, "--quiet")
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        rows = read_csv(os.path.join(out, "bench.csv"))
        self.assertEqual(len(rows), 4)
        self.assertEqual({r["scheme"] for r in rows}, {"moreau-jean", "catching-up"})
        self.assertEqual(sorted(int(r["steps"]) for r in rows), [20, 20, 40, 40])
        for png in ("cpu_and_penetration_vs_dt.png", "cpu_vs_penetration.png",
                    "iterations_per_step.png"):
            path = os.path.join(out, png)
            self.assertTrue(os.path.exists(path), png)
            with open(path, "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
            self.assertGreater(os.path.getsize(path), 1000)
        self.assertEqual(leftovers(out), [])

    def test_a_step_given_twice_is_refused_before_any_run(self):
        # the same value twice, or two values that name the same point's folder
        for steps, first, second in [("1e-3,2e-4,1e-3", "0.001", "0.001"),
                                     ("1e-3,0.0010000001", "0.001", "0.0010000001")]:
            out = scratch_dir(self, "sweep_bench_")
            r = sweep("bench", "small_box.yaml", "--dt", steps, "--out", out, "--quiet")
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertIn(f"--dt: {first} and {second} are the same point (runs/*_dt0.001); "
                          "give each step once", r.stderr)
            self.assertFalse(os.path.exists(os.path.join(out, "runs")))


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
