#!/usr/bin/python3
"""Two builds of the `sweep` command side by side: each case run with the build before and the
build after, alternating, --repeat times; the least wall time and the least solve time of each
(stats.csv's t_solve summed), their ratio after / before, and whether both ended in the same
final_state.csv, bit for bit. For changes that must not cost time (a refactor):

  /usr/bin/python3 bench/compare_builds.py BEFORE/sweep AFTER/sweep [--repeat 3] [--cases a,b]
      [--threads 1]
"""
import argparse
import csv
import filecmp
import json
import os
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FUNNEL = os.path.join(ROOT, "examples", "funnel", "funnel.yaml")
POWDER = os.path.join(ROOT, "examples", "powder_bed", "powder_bed_reduced.yaml")
FAST = os.path.join(ROOT, "examples", "powder_bed", "fast.yaml")
FUNNEL_500 = ["--set", "generators[0].count=500",
              "--set", "generators[0].orifice=0.008032185256827685"]
NLGS_STAGES = ["--set", "scheme.normal_stage.solver=nlgs",
               "--set", "scheme.friction_stage.solver=nlgs"]
CASES = {
    "funnel_500 moreau-jean": [FUNNEL, "--scheme", "moreau-jean", *FUNNEL_500],
    "funnel_500 catching-up": [FUNNEL, "--scheme", "catching-up", *FUNNEL_500],
    "funnel_500 catching-up nlgs": [FUNNEL, "--scheme", "catching-up", *FUNNEL_500, *NLGS_STAGES],
    "powder heap moreau-jean": [POWDER, "--scheme", "moreau-jean", "--t-end", "0.02"],
    "powder heap catching-up": [POWDER, "--scheme", "catching-up", "--t-end", "0.02"],
    "powder heap catching-up nlgs": [POWDER, "--scheme", "catching-up", "--t-end", "0.02",
                                     *NLGS_STAGES],
    "powder fast moreau-jean": [POWDER, "--scheme", "moreau-jean", "--set-file", FAST],
}


def run(sweep, argv, out, threads):
    subprocess.run([sweep, "run", argv[0], "--out", out, "--quiet", "--threads", str(threads),
                    "--set", "output.vtk_interval=0", *argv[1:]], check=True,
                   stdout=subprocess.DEVNULL)
    with open(os.path.join(out, "summary.json")) as f:
        wall = json.load(f)["wall_seconds"]
    with open(os.path.join(out, "stats.csv")) as f:
        solve = sum(float(r["t_solve"]) for r in csv.DictReader(f))
    return wall, solve


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--cases", default=",".join(CASES))
    args = parser.parse_args()
    builds = {"before": os.path.abspath(args.before), "after": os.path.abspath(args.after)}
    print("| case | wall before (s) | wall after (s) | ratio | solve before (s) | solve after (s) "
          "| ratio | same bits |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as work:
        for name in args.cases.split(","):
            best = {k: [float("inf"), float("inf")] for k in builds}
            for i in range(args.repeat):
                for key, sweep in builds.items():
                    wall, solve = run(sweep, CASES[name], os.path.join(work, key), args.threads)
                    best[key] = [min(best[key][0], wall), min(best[key][1], solve)]
            same = filecmp.cmp(os.path.join(work, "before", "final_state.csv"),
                               os.path.join(work, "after", "final_state.csv"), shallow=False)
            b, a = best["before"], best["after"]
            print(f"| {name} | {b[0]:.3f} | {a[0]:.3f} | {a[0] / b[0]:.3f} | {b[1]:.3f} | "
                  f"{a[1]:.3f} | {a[1] / b[1]:.3f} | {'yes' if same else 'no'} |", flush=True)


if __name__ == "__main__":
    main()
