#!/usr/bin/python3
"""Two builds of the `sweep` command side by side: each case run with the build before and the
build after, alternating, --repeat times; the least wall time, the least solve time (stats.csv's
t_solve summed) and the least solve time per local update (summary.json's ns_per_update: the
fair measure where the two builds take other trajectories) of each, their ratios after /
before, and whether both ended in the same final_state.csv, bit for bit. For changes that must
not cost time (a refactor):

  /usr/bin/python3 bench/compare_builds.py BEFORE/sweep AFTER/sweep [--repeat 3] [--cases a,b]
      [--threads 1] [--powder-state SETTLED.csv] [--wide-state SETTLED_X10.csv]

The last two add the full bed's spreading pass at the fast setting ("powder pass") and the wide
bed's first 100 steps of it ("wide bed"), from the states docs/benchmarks.md, "Threads", makes.
"""
import argparse
import filecmp
import json
import os
import tempfile

from mesh_bowl import write_scene  # 196 spheres poured into a 16 256-triangle bowl
from threads import run  # one run: (wall, [detect, assemble, solve, update] seconds)
from threads import POWDER as BED

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FUNNEL = os.path.join(ROOT, "examples", "funnel", "funnel.yaml")
POWDER = os.path.join(ROOT, "examples", "powder_bed", "powder_bed_reduced.yaml")
FAST = os.path.join(ROOT, "examples", "powder_bed", "fast.yaml")
ARM = os.path.join(ROOT, "examples", "archetypes", "arm_on_table.yaml")
ROCKING = os.path.join(ROOT, "examples", "archetypes", "rocking_block.yaml")
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
    # small scenes: the step's fixed costs
    "arm on table moreau-jean": [ARM, "--scheme", "moreau-jean", "--t-end", "20"],
    "arm on table catching-up": [ARM, "--scheme", "catching-up", "--t-end", "20"],
    "rocking block catching-up": [ROCKING, "--scheme", "catching-up", "--t-end", "10"],
    # a large triangle mesh: the scene is written into the run's folder (bench/mesh_bowl.py)
    "mesh bowl pour": ["MESH_BOWL", "--scheme", "moreau-jean"],
}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--powder-state")
    parser.add_argument("--wide-state")
    args = parser.parse_args()
    if args.powder_state:
        CASES["powder pass"] = [BED, "--initial-state", args.powder_state, "--set-file", FAST]
    if args.wide_state:
        # 100 steps from the settled state's 0.02101 s
        CASES["wide bed"] = [BED, "--initial-state", args.wide_state, "--set-file", FAST,
                             "--set", "generators[0].copies_across=10", "--t-end", "0.031"]
    builds = {"before": os.path.abspath(args.before), "after": os.path.abspath(args.after)}
    print("| case | wall before (s) | wall after (s) | ratio | solve before (s) | solve after (s) "
          "| ratio | ns / update before | after | ratio | detect before (s) | after | ratio "
          "| same bits |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as work:
        bowl = write_scene(os.path.join(work, "mesh_bowl"))
        for name in args.cases.split(","):
            best = {k: [float("inf")] * 4 for k in builds}
            for i in range(args.repeat):
                for key, sweep in builds.items():
                    out = os.path.join(work, key)
                    case = [bowl if a == "MESH_BOWL" else a for a in CASES[name]]
                    wall, split = run(sweep, case, out, args.threads, [])
                    with open(os.path.join(out, "summary.json")) as f:
                        per_update = json.load(f)["solver"]["ns_per_update"]
                    best[key] = [min(x, y) for x, y in
                                 zip(best[key], (wall, split[2], per_update, split[0]))]
            same = filecmp.cmp(os.path.join(work, "before", "final_state.csv"),
                               os.path.join(work, "after", "final_state.csv"), shallow=False)
            b, a = best["before"], best["after"]
            print(f"| {name} | {b[0]:.3f} | {a[0]:.3f} | {a[0] / b[0]:.3f} | {b[1]:.3f} | "
                  f"{a[1]:.3f} | {a[1] / b[1]:.3f} | {b[2]:.1f} | {a[2]:.1f} | {a[2] / b[2]:.3f} | "
                  f"{b[3]:.3f} | {a[3]:.3f} | {a[3] / b[3]:.3f} | {'yes' if same else 'no'} |",
                  flush=True)


if __name__ == "__main__":
    main()
