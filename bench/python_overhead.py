#!/usr/bin/python3
"""What the Python module costs over the C++ it calls, measured side by side in one run:

- the funnel run whole: `sweep run` against sweep.run() and Simulation.run() (wall time, the
  least of --repeat runs, alternating; results written by both);
- the funnel stepped one Python call per step (Simulation.step()) against Simulation.run();
- per call on examples/archetypes/arm6.urdf: bias_forces, mass_matrix, forward_dynamics from
  Python (timeit, the least of 7 batches) against the same functions in C++
  (./build/bench/dynamics_bench, Google Benchmark).

From a built tree:  PYTHONPATH=build/python /usr/bin/python3 bench/python_overhead.py
"""
import argparse
import json
import os
import subprocess
import tempfile
import time
import timeit

import numpy as np

import sweep

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FUNNEL = os.path.join(ROOT, "examples", "funnel", "funnel.yaml")
ARM = os.path.join(ROOT, "examples", "archetypes", "arm6.urdf")


def wall(work):
    start = time.perf_counter()
    work()
    return time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    cli = os.path.join(args.build, "sweep")
    out = tempfile.mkdtemp(prefix="sweep_python_overhead_")
    settings = {"output.vtk_interval": 0}

    def stepped():
        sim = sweep.Simulation(FUNNEL)
        for _ in range(round(sim.t_end / sim.dt)):
            sim.step()

    runs = {
        "sweep run": lambda: subprocess.run(
            [cli, "run", FUNNEL, "--out", os.path.join(out, "cli"), "--quiet",
             "--set", "output.vtk_interval=0"], check=True, stdout=subprocess.DEVNULL),
        "sweep.run()": lambda: sweep.run(FUNNEL, out=os.path.join(out, "py"), overrides=settings),
        "Simulation.run()": lambda: sweep.Simulation(FUNNEL).run(),
        "Simulation.step() per step": stepped,
    }
    best = {name: float("inf") for name in runs}
    for _ in range(args.repeat):
        for name, work in runs.items():
            best[name] = min(best[name], wall(work))
    print("| funnel, 50 disks, 1000 steps | wall (s) | against `sweep run` |")
    print("|---|---|---|")
    for name in runs:
        print(f"| {name} | {best[name]:.4f} | {best[name] / best['sweep run']:.3f} |")
    print(f"\nstepping one call per step against Simulation.run(): "
          f"{best['Simulation.step() per step'] / best['Simulation.run()']:.3f}")

    bench = subprocess.run([os.path.join(args.build, "bench", "dynamics_bench"),
                            "--benchmark_filter=Arm6Urdf", "--benchmark_format=json",
                            "--benchmark_min_time=0.5"],
                           check=True, capture_output=True, text=True)
    cpp = {b["name"].split("_", 2)[2]: b["real_time"] / 1e3  # ns -> us
           for b in json.loads(bench.stdout)["benchmarks"]}
    model = sweep.Model.from_urdf(ARM)
    q = np.linspace(-0.7, 0.9, model.nq)
    v = np.linspace(0.4, -0.6, model.nv)
    # statements timed as written, without a lambda's own call around them
    calls = {"BiasForces": "model.bias_forces(q, v)",
             "MassMatrix": "model.mass_matrix(q)",
             "ForwardDynamics": "model.forward_dynamics(q, v, v)"}
    names = {"model": model, "q": q, "v": v}
    print("\n| arm6.urdf, per call | C++ (us) | Python (us) | overhead (us) |")
    print("|---|---|---|---|")
    for name, call in calls.items():
        n = 20000
        python = min(timeit.repeat(call, number=n, repeat=7, globals=names)) / n * 1e6
        print(f"| {name} | {cpp[name]:.3f} | {python:.3f} | {python - cpp[name]:.3f} |")


if __name__ == "__main__":
    main()
