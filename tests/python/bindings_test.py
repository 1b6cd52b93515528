#!/usr/bin/python3
"""The `sweep` Python module against the `sweep` command and the C++ layer: a scene stepped
from Python ends in the same bits as `sweep run`; run() returns summary.json's figures; input
errors are sweep.InputError with the command's message; Ctrl-C stops a run; the URDF layer's
identities (M symmetric positive definite, M a + bias = tau, bias = gravity + Coriolis).
Usage: bindings_test.py SWEEP SOURCE_DIR (with the module on PYTHONPATH)"""
import csv
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import unittest

import numpy as np

import sweep
from scratch import scratch_dir

SWEEP = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else "sweep"
SOURCE = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else "."
FUNNEL = os.path.join(SOURCE, "examples/funnel/funnel.yaml")
ARM = os.path.join(SOURCE, "examples/archetypes/arm6.urdf")


def final_state(folder):
    with open(os.path.join(folder, "final_state.csv")) as f:
        rows = list(csv.DictReader(f))
    return {name: np.array([float(r["value"]) for r in rows if r["vector"] == name])
            for name in ("t", "q", "v")}


class Scenes(unittest.TestCase):
    def test_stepping_gives_the_bits_of_sweep_run(self):
        for scheme in ("moreau-jean", "catching-up"):
            out = scratch_dir(self, "sweep_py_")
            subprocess.run([SWEEP, "run", FUNNEL, "--scheme", scheme, "--t-end", "0.03", "--out",
                            out, "--quiet", "--set", "output.vtk_interval=0"], check=True,
                           capture_output=True)
            cli = final_state(out)
            sim = sweep.Simulation(FUNNEL, scheme=scheme)
            steps = sim.run(t_end=0.03)
            self.assertEqual(steps, 300)
            self.assertEqual(sim.t, cli["t"][0])
            np.testing.assert_array_equal(sim.q, cli["q"])
            np.testing.assert_array_equal(sim.v, cli["v"])
            self.assertGreater(len(sim.contacts()["gap"]), 10)

    def test_a_scene_built_in_code_runs_as_its_file_does(self):
        scene = {
            "dimension": 2, "gravity": [0, -9.81],
            "materials": {"steel": {"density": 7800}},
            "contact": {"friction": 0.3, "restitution": 0.5},
            "bodies": [
                {"name": "floor", "shape": "half_plane", "position": [0, 0], "normal": [0, 1],
                 "fixed": True, "material": "steel"},
                {"name": "disk", "shape": "disk", "radius": 0.01, "position": [0, 0.05],
                 "velocity": [0.2, 0], "material": "steel"},
            ],
            "time": {"step": 1e-4, "end": 0.1},
        }
        folder = scratch_dir(self, "sweep_py_")
        path = os.path.join(folder, "scene.yaml")
        with open(path, "w") as f:
            json.dump(scene, f)  # JSON is YAML
        subprocess.run([SWEEP, "run", path, "--out", os.path.join(folder, "out"), "--quiet"],
                       check=True, capture_output=True)
        cli = final_state(os.path.join(folder, "out"))
        sim = sweep.Simulation(scene)
        sim.run()
        np.testing.assert_array_equal(sim.q, cli["q"])
        with self.assertRaises(sweep.InputError) as error:
            sweep.Simulation(dict(scene, time={"step": -1.0, "end": 0.1}))
        self.assertIn("<scene dict>: time.step", str(error.exception))

    def test_run_returns_the_summary(self):
        out = scratch_dir(self, "sweep_py_")
        summary = sweep.run(FUNNEL, out=out, t_end=0.02, overrides={"output.vtk_interval": 0})
        with open(os.path.join(out, "summary.json")) as f:
            written = json.load(f)
        for key in ("scheme", "dt", "steps", "penetration", "iterations", "energy"):
            self.assertEqual(summary[key], written[key], key)
        self.assertEqual(summary["steps"], 200)

    def test_step_by_step_with_a_callback(self):
        sim = sweep.Simulation(FUNNEL, overrides={"scheme.name": "moreau-jean"})
        times = []
        steps = sim.run(t_end=0.005, callback=lambda s: times.append(s.t) or len(times) < 20)
        self.assertEqual(steps, 20)
        self.assertEqual(len(times), 20)
        self.assertAlmostEqual(times[-1], 20 * sim.dt)
        stats = sim.step()
        self.assertEqual(stats["step"], 21)
        self.assertEqual(sim.scheme, "moreau-jean")

    def test_state_views_and_set_state(self):
        sim = sweep.Simulation(FUNNEL)
        q = sim.q
        self.assertFalse(q.flags.writeable)
        with self.assertRaises(ValueError):
            q[0] = 1.0
        q0, v0 = np.array(sim.q), np.array(sim.v)
        sim.run(t_end=0.002)
        sim.set_state(0.0, q0, v0)
        self.assertEqual(sim.t, 0.0)
        np.testing.assert_array_equal(sim.q, q0)
        # checked as a saved state is: the state is kept when the new one is refused
        far, fast = q0.copy(), v0.copy()
        far[0], fast[0] = 1e300, 1e300
        for t, q_new, v_new in ((float("nan"), q0, v0), (0.0, far, v0), (0.0, q0, fast),
                                (0.0, q0[:-1], v0)):
            with self.assertRaises(sweep.InputError):
                sim.set_state(t, q_new, v_new)
        np.testing.assert_array_equal(sim.q, q0)

    def test_set_state_checks_joint_limits_as_a_saved_state_does(self):
        # arm_on_table's joint2 is limited to [-0.3, 0.6] rad; it is q[1]
        sim = sweep.Simulation(os.path.join(SOURCE, "examples/archetypes/arm_on_table.yaml"))
        q0, v0 = np.array(sim.q), np.array(sim.v)
        past = q0.copy()
        past[1] = 1.0
        with self.assertRaises(sweep.InputError) as error:
            sim.set_state(0.0, past, v0)
        self.assertIn("joint 'joint2' is at 1 rad", str(error.exception))
        self.assertIn("past its upper limit 0.6", str(error.exception))
        with self.assertRaises(sweep.InputError):
            sim.set_state(-1.0, q0, v0)
        np.testing.assert_array_equal(sim.q, q0)

    def test_input_errors_carry_the_command_line_message(self):
        bad = {"generators[0].count": -5}
        result = subprocess.run([SWEEP, "check", FUNNEL, "--set", "generators[0].count=-5"],
                                capture_output=True, text=True)
        self.assertEqual(result.returncode, 2)
        with self.assertRaises(sweep.InputError) as error:
            sweep.Simulation(FUNNEL, overrides=bad)
        self.assertIn(str(error.exception), result.stderr)
        self.assertIsInstance(error.exception, ValueError)
        with self.assertRaises(sweep.InputError):
            sweep.run(os.path.join(SOURCE, "no_such_scene.yaml"))
        with self.assertRaises(sweep.InputError):
            sweep.Simulation(FUNNEL, dt=-1.0)
        with self.assertRaises(sweep.InputError):
            sweep.Simulation(FUNNEL, scheme="leapfrog")

    def test_a_state_that_runs_away_raises(self):
        scene = os.path.join(SOURCE, "tests/data/scenes/runaway.yaml")
        out = scratch_dir(self, "sweep_py_runaway_")
        with self.assertRaises(RuntimeError) as error:
            sweep.run(scene, out=out)
        self.assertIn("body 'ball' has run away", str(error.exception))
        with open(os.path.join(out, "summary.json")) as f:
            self.assertIn("has run away", json.load(f)["failure"])
        sim = sweep.Simulation(scene)
        with self.assertRaises(RuntimeError) as error:
            sim.run(0.01)
        self.assertIn("step 1 (t = 0.001 s)", str(error.exception))

    def test_ctrl_c_stops_a_run(self):
        script = textwrap.dedent(f"""
            import sys, time
            import sweep
            sim = sweep.Simulation({FUNNEL!r}, overrides={{"generators[0].count": 500,
                                   "generators[0].orifice": 0.008}})
            print("ready", flush=True)
            start = time.time()
            try:
                sim.run(t_end=100.0)
            except KeyboardInterrupt:
                print("interrupted at", sim.t, "after", round(time.time() - start, 2), flush=True)
                sys.exit(0)
            sys.exit(1)
            """)
        env = dict(os.environ)
        process = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                                   text=True, env=env)
        self.assertEqual(process.stdout.readline().strip(), "ready")
        time.sleep(1.0)
        process.send_signal(signal.SIGINT)
        out, _ = process.communicate(timeout=30)
        self.assertEqual(process.returncode, 0, out)
        self.assertIn("interrupted at", out)
        t = float(out.split()[2])
        self.assertGreater(t, 0.0)
        self.assertLess(t, 100.0)


class Actuators(unittest.TestCase):
    TURNTABLE = os.path.join(SOURCE, "tests/data/urdf/turntable.urdf")

    def turntable(self, actuator, scheme="moreau-jean"):
        return sweep.Simulation({"dimension": 3,
                                 "urdf": [{"file": self.TURNTABLE,
                                           "actuators": {"spin": actuator}}],
                                 "time": {"step": 1e-3, "end": 1.0}}, scheme=scheme)

    def test_a_controller_commands_the_torque_each_step(self):
        # tau = -2 v from Python on I = 0.5: v decays as exp(-4 t)
        for scheme in ("moreau-jean", "catching-up"):
            sim = self.turntable({"torque": 0}, scheme)
            self.assertEqual(sim.actuators, ["spin"])
            self.assertEqual(sim.dof_names, ["spin"])
            sim.set_state(0.0, np.zeros(1), np.array([1.0]))

            def damp(s):
                s.command("spin", torque=-2.0 * s.v[0])
            sim.run(t_end=0.5, callback=damp)
            # the callback runs after each step: step 1 has no torque, step k the torque of
            # v_{k-1}, an explicit damper: v_k = (1 - 4h)^(k-1)
            self.assertAlmostEqual(sim.v[0], (1 - 4e-3) ** 499, delta=1e-12)
            self.assertAlmostEqual(sim.actuator_torques()[0], -2.0 * (1 - 4e-3) ** 498,
                                   delta=1e-12)

    def test_a_commanded_position_overrides_the_table(self):
        sim = self.turntable({"kp": 1e3, "kd": 60, "position": 0.0, "max_torque": 1e6})
        sim.command("spin", position=0.5)
        sim.run(t_end=1.0)
        self.assertAlmostEqual(sim.q[0], 0.5, delta=1e-6)
        sim.command("spin")  # back to the table
        sim.run(t_end=2.0)
        self.assertAlmostEqual(sim.q[0], 0.0, delta=1e-6)

    def test_a_prescribed_joint_takes_a_commanded_motion(self):
        # the turntable prescribed to rest at 0; commanded to turn at 2 rad/s from where it is,
        # then handed back to its table (which the constraint reaches within two steps)
        for scheme in ("moreau-jean", "catching-up"):
            sim = self.turntable({"prescribed": 0.0}, scheme)
            sim.run(t_end=0.1)
            self.assertAlmostEqual(sim.q[0], 0.0, delta=1e-12)
            sim.command("spin", velocity=2.0)  # from its q now
            sim.run(t_end=0.6)
            self.assertAlmostEqual(sim.q[0], 2.0 * 0.5, delta=1e-9)
            self.assertAlmostEqual(sim.v[0], 2.0, delta=1e-9)
            # turning at a constant rate on a frictionless axis: no torque past the start
            self.assertAlmostEqual(sim.actuator_torques()[0], 0.0, delta=1e-6)
            sim.command("spin", position=0.25)  # held there
            sim.run(t_end=0.7)
            self.assertAlmostEqual(sim.q[0], 0.25, delta=1e-9)
            self.assertAlmostEqual(sim.v[0], 0.0, delta=1e-9)
            sim.command("spin")
            sim.run(t_end=0.8)
            self.assertAlmostEqual(sim.q[0], 0.0, delta=1e-9)
            with self.assertRaises(sweep.InputError) as error:
                sim.command("spin", torque=1.0)
            self.assertIn("not a torque", str(error.exception))

    def test_names_of_joints_bodies_and_contacts(self):
        sim = sweep.Simulation(os.path.join(SOURCE, "examples/archetypes/arm_pushes_blocks.yaml"),
                               scheme="catching-up")
        sim.run(t_end=1.75)  # the wrist pushes block_a
        joint = sim.joint("joint2")
        self.assertEqual(sim.dof_names[joint["v_index"]], "joint2")
        self.assertEqual(joint["q"][0], sim.q[joint["q_index"]])
        self.assertEqual(joint["body"], "link2")
        block = sim.body("block_a")
        q_block = sim.q[0:3]  # the scene's bodies come first
        np.testing.assert_array_equal(block["position"], q_block)
        contacts = sim.contacts()
        pairs = {tuple(sorted(p)) for p in zip(contacts["name_a"], contacts["name_b"])}
        self.assertIn(("block_a", "table"), pairs)
        self.assertIn(("block_a", "link6"), pairs)
        with self.assertRaises(sweep.InputError):
            sim.body("nobody")
        with self.assertRaises(sweep.InputError):
            sim.joint("joint9")

    def test_bad_commands_are_input_errors(self):
        sim = self.turntable({"torque": 0})
        with self.assertRaises(sweep.InputError) as error:
            sim.command("wrist", torque=1.0)
        self.assertIn("no actuator on a joint named 'wrist'", str(error.exception))
        with self.assertRaises(sweep.InputError) as error:
            sim.command("spin", torque=float("nan"))
        self.assertIn("torque = nan must be finite", str(error.exception))
        with self.assertRaises(sweep.InputError) as error:
            sim.command("spin", position=1.0)
        self.assertIn("no servo gains", str(error.exception))


class Equations(unittest.TestCase):
    """Systems by their equations and constraints by functions from Python callables."""

    def point_on_floor(self, scheme, e=0.0):
        m, g = 2.0, 9.81
        point = sweep.System("point", 2, 2, mass=lambda q: m * np.eye(2),
                             forces=lambda t, q, v: np.array([0.0, -m * g]),
                             potential=lambda q: m * g * q[1])
        floor = sweep.Constraint("floor", gap=lambda q: q[1], normal=lambda q: [0.0, 1.0],
                                 tangent=lambda q: [1.0, 0.0], friction=0.4, restitution=e)
        return sweep.Simulation.from_equations([point], [floor], q0=[0.0, 0.1], v0=[1.0, 0.0],
                                               dt=1e-3, t_end=1.0, scheme=scheme)

    def test_a_point_lands_slides_and_stops(self):
        for scheme in ("moreau-jean", "catching-up"):
            sim = self.point_on_floor(scheme)
            self.assertEqual(sim.run(), 1000)
            self.assertAlmostEqual(sim.v[0], 0.0, places=9)
            self.assertAlmostEqual(sim.constraint_impulses()[0, 0], 2.0 * 9.81 * 1e-3,
                                   places=9)
            self.assertLess(sim.energy(), 1.0)

    def test_a_bilateral_rod_pulls(self):
        m, length, g = 1.5, 0.5, 9.81
        bob = sweep.System("bob", 2, 2, mass=lambda q: m * np.eye(2),
                           forces=lambda t, q, v: np.array([0.0, -m * g]))
        rod = sweep.Constraint("rod", gap=lambda q: np.linalg.norm(q) - length,
                               normal=lambda q: q / np.linalg.norm(q), bilateral=True)
        sim = sweep.Simulation.from_equations([bob], [rod], q0=[0.05, -length], v0=[0.0, 0.0],
                                              dt=1e-3)
        sim.run(t_end=0.5)
        # the tension, m g h per step at rest, points against the rod's normal
        self.assertLess(sim.constraint_impulses()[0, 0], -0.9 * m * g * 1e-3)
        self.assertLess(abs(np.linalg.norm(sim.q) - np.hypot(0.05, length)), 1e-3)
        with self.assertRaises(sweep.InputError):
            sweep.Simulation.from_equations(
                [bob], [sweep.Constraint("rod", gap=lambda q: q[0], normal=lambda q: [1.0, 0.0],
                                         tangent=lambda q: [0.0, 1.0], friction=0.5,
                                         bilateral=True)],
                q0=[0.0, 0.0], v0=[0.0, 0.0], dt=1e-3)

    def test_from_equations_checks_its_start_and_step_as_a_scene_file_is(self):
        bob = sweep.System("bob", 2, 2, mass=lambda q: np.eye(2),
                           forces=lambda t, q, v: np.array([0.0, -9.81]))
        for q0, v0, dt, message in (([float("nan"), 0.0], [0.0, 0.0], 1e-3,
                                     "q[0] = nan is not finite"),
                                    ([0.0, 0.0], [0.0, float("inf")], 1e-3,
                                     "v[1] = inf is not finite"),
                                    ([0.0, 0.0], [0.0, 0.0], 5.0, "is longer than 1 s")):
            with self.assertRaises(sweep.InputError) as error:
                sweep.Simulation.from_equations([bob], [], q0=q0, v0=v0, dt=dt, t_end=10.0)
            self.assertIn(message, str(error.exception))
        with self.assertRaises(sweep.InputError) as error:
            sweep.Simulation(FUNNEL, dt=2.0)
        self.assertIn("time.step = 2 s is longer than 1 s", str(error.exception))

    def test_a_system_beside_a_scene_body_moves_as_it_does(self):
        # V4's scene (a disk rolling down a slope), and beside its body the same disk as
        # q = (x, y, theta), M = diag(m, m, I), the slope a constraint by functions: both roll
        # alike, to round-off, in one simulation and both schemes
        scene = os.path.join(SOURCE, "examples/archetypes/disk_on_incline.yaml")
        m, radius, g = 1.0, 0.1, 9.81
        n = np.array([-0.6, 1.0]) / np.hypot(0.6, 1.0)
        t = np.array([n[1], -n[0]])
        r_c = -radius * n
        for scheme in ("moreau-jean", "catching-up"):
            disk = sweep.System("disk", 3, 3, mass=lambda q: np.diag([m, m, 0.5 * m * radius**2]),
                                forces=lambda t_, q, v: np.array([0.0, -m * g, 0.0]),
                                constant_mass=True, reference=[radius * n[0], radius * n[1], 0.0])
            slope = sweep.Constraint(
                "slope", gap=lambda q: n @ q[3:5] - radius,
                normal=lambda q: [0, 0, 0, n[0], n[1], 0],
                tangent=lambda q: [0, 0, 0, t[0], t[1], r_c[0] * t[1] - r_c[1] * t[0]],
                friction=0.25)
            sim = sweep.Simulation(scene, scheme=scheme, systems=[disk], constraints=[slope])
            self.assertEqual(len(sim.q), 6)
            self.assertEqual(sim.run(t_end=0.3), 300)
            self.assertLess(np.max(np.abs(sim.q[:3] - sim.q[3:])), 1e-12)
            self.assertLess(sim.v[0], -0.5)  # it rolled down the slope

    def test_errors_in_callables_reach_the_caller(self):
        def broken(t, q, v):
            raise ZeroDivisionError("inside forces")
        system = sweep.System("broken", 1, 1, mass=lambda q: 1.0, forces=broken)
        sim = sweep.Simulation.from_equations([system], q0=[0.0], v0=[0.0], dt=1e-3)
        with self.assertRaises(ZeroDivisionError):
            sim.run(t_end=0.01)
        wrong = sweep.System("wrong", 1, 1, mass=lambda q: np.eye(2))
        with self.assertRaises(RuntimeError) as error:
            sim = sweep.Simulation.from_equations([wrong], q0=[0.0], v0=[0.0], dt=1e-3)
            sim.step()
        self.assertIn("system 'wrong': its mass matrix must be a finite 1 x 1 matrix",
                      str(error.exception))
        with self.assertRaises(sweep.InputError):
            sweep.System("short", 2, 1, mass=lambda q: np.eye(1))  # nq != nv, no integrate
            sweep.Simulation.from_equations([sweep.System("short", 2, 1,
                                                          mass=lambda q: np.eye(1))],
                                            q0=[0.0, 0.0], v0=[0.0], dt=1e-3)
        with self.assertRaises(sweep.InputError):
            sweep.Simulation.from_equations([system], q0=[0.0, 1.0], v0=[0.0], dt=1e-3)


class Urdf(unittest.TestCase):
    def setUp(self):
        self.model = sweep.Model.from_urdf(ARM)
        rng = np.random.default_rng(3)
        self.q = rng.uniform(-1, 1, self.model.nq)
        self.v = rng.uniform(-1, 1, self.model.nv)

    def test_names(self):
        self.assertEqual(len(self.model.dof_names), self.model.nv)
        for k, name in enumerate(self.model.dof_names):
            self.assertEqual(self.model.dof_index(name), k)
        with self.assertRaises(sweep.InputError):
            self.model.dof_index("no such joint")

    def test_dynamics_identities(self):
        m, q, v = self.model, self.q, self.v
        M = m.mass_matrix(q)
        np.testing.assert_allclose(M, M.T, atol=1e-14)
        self.assertGreater(np.linalg.eigvalsh(M).min(), 0.0)
        tau = np.linspace(-1, 1, m.nv)
        a = m.forward_dynamics(q, v, tau)
        np.testing.assert_allclose(M @ a + m.bias_forces(q, v), tau, atol=1e-12)
        np.testing.assert_allclose(m.rnea(q, v, a), tau, atol=1e-12)
        np.testing.assert_allclose(m.gravity_forces(q) + m.coriolis_forces(q, v),
                                   m.bias_forces(q, v), atol=1e-12)
        self.assertAlmostEqual(m.kinetic_energy(q, v), 0.5 * v @ M @ v, places=12)
        # the Coriolis forces are quadratic in v, and zero without it
        np.testing.assert_allclose(m.coriolis_forces(q, 2 * v), 4 * m.coriolis_forces(q, v),
                                   atol=1e-12)
        np.testing.assert_array_equal(m.coriolis_forces(q, 0 * v), np.zeros(m.nv))

    def test_jacobian_is_the_derivative_of_the_pose(self):
        # J v against central differences of the body pose along q + eps v (nq = nv here)
        m, q, v, eps = self.model, self.q, self.v, 1e-6
        self.assertEqual(m.nq, m.nv)
        body = m.body_names[-1]
        point = np.array([0.05, -0.02, 0.1])
        J = m.jacobian(q, body, point)
        self.assertEqual(J.shape, (6, m.nv))
        (R1, p1), (R0, p0) = m.body_pose(q + eps * v, body), m.body_pose(q - eps * v, body)
        velocity = (R1 @ point + p1 - R0 @ point - p0) / (2 * eps)
        np.testing.assert_allclose(J[3:] @ v, velocity, atol=1e-8)
        W = (R1 - R0) / (2 * eps) @ m.body_pose(q, body)[0].T  # the skew matrix of omega
        np.testing.assert_allclose(J[:3] @ v, [W[2, 1], W[0, 2], W[1, 0]], atol=1e-8)
        np.testing.assert_array_equal(m.jacobian(q, body)[:3], J[:3])
        with self.assertRaises(sweep.InputError):
            m.jacobian(q, "no such body")

    def test_floating_base_velocity_conventions(self):
        m = sweep.Model.from_urdf(ARM, floating_base=True)
        self.assertEqual(m.dof_names[:6], ["root_joint:vx", "root_joint:vy", "root_joint:vz",
                                           "root_joint:wx", "root_joint:wy", "root_joint:wz"])
        q = m.neutral_configuration()
        angle = 0.7  # the root turned about z: its quaternion (x, y, z, w) in q[3:7]
        q[3:7] = [0.0, 0.0, np.sin(angle / 2), np.cos(angle / 2)]
        v = np.arange(1.0, m.nv + 1.0)
        body = m.velocity_to_body_frame(q, v)
        c, s = np.cos(angle), np.sin(angle)
        np.testing.assert_allclose(body[:3], [c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]],
                                   atol=1e-14)
        np.testing.assert_array_equal(body[3:], v[3:])
        np.testing.assert_allclose(m.velocity_from_body_frame(q, body), v, atol=1e-14)

    def test_bad_sizes_are_input_errors(self):
        with self.assertRaises(sweep.InputError):
            self.model.mass_matrix(np.zeros(self.model.nq + 1))
        with self.assertRaises(sweep.InputError):
            self.model.bias_forces(self.q, np.full(self.model.nv, np.nan))
        with self.assertRaises(sweep.InputError):
            sweep.Model.from_urdf(os.path.join(SOURCE, "no_such.urdf"))


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
