#!/usr/bin/env python3
"""The staggered scheme's stage solvers side by side: NLGS against the convex solvers (MPRGP,
APGD on discs) on the same scenes, run alternately in one invocation, with Jean-Moreau as the
reference. Prints a Markdown table (CPU time, iterations per stage, cap hits, penetration)
and writes OUT/stage_solvers.csv. From a built tree:

  /usr/bin/python3 bench/stage_solvers.py --out results/stage_solvers
  /usr/bin/python3 bench/stage_solvers.py --cases funnel --dt 1e-3,1e-4 -- --set scheme.normal_law=pos

Everything after `--` goes to every run.
"""
import argparse
import csv
import json
import os
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# name: (scene, extra options)
CASES = {
    "funnel": ("examples/funnel/funnel.yaml", []),
    "funnel_500": ("examples/funnel/funnel.yaml",
                   ["--set", "generators[0].count=500",
                    "--set", "generators[0].orifice=0.008032185256827685"]),
    "slider_crank": ("examples/archetypes/slider_crank.yaml", []),
    # 80 000 touching disks at rest in a box, 20 steps: the whole pile closes in the first step
    "pile_2d": ("bench/scenes/touching_pile_2d.yaml", []),
    # 8 000 touching spheres at rest in a box, 10 steps: the 3D pile
    "pile_3d": ("bench/scenes/touching_pile_3d.yaml", []),
    # the reduced powder bed's heap settling (800 spheres, the first 20 ms), both stages at the
    # solvers' default tolerance (the scene's own is 1e-3)
    "powder_heap": ("examples/powder_bed/powder_bed_reduced.yaml",
                    ["--t-end", "0.02", "--set", "scheme.normal_stage.tolerance=1e-6",
                     "--set", "scheme.friction_stage.tolerance=1e-6"]),
}
CONFIGS = [
    ("moreau-jean", ["--scheme", "moreau-jean"]),
    ("catching-up nlgs", ["--scheme", "catching-up", "--set", "scheme.normal_stage.solver=nlgs",
                          "--set", "scheme.friction_stage.solver=nlgs"]),
    ("catching-up nncg", ["--scheme", "catching-up", "--set", "scheme.normal_stage.solver=nlgs",
                          "--set", "scheme.friction_stage.solver=nlgs",
                          "--set", "scheme.normal_stage.acceleration=nncg",
                          "--set", "scheme.friction_stage.acceleration=nncg"]),
    ("catching-up mprgp", ["--scheme", "catching-up", "--set", "scheme.normal_stage.solver=mprgp",
                           "--set", "scheme.friction_stage.solver=mprgp"]),
    ("catching-up newton", ["--scheme", "catching-up", "--set", "scheme.normal_stage.solver=newton",
                            "--set", "scheme.friction_stage.solver=newton"]),
    ("catching-up", ["--scheme", "catching-up"]),
    # the row storages' worth (docs/architecture.md, "Contact rows in two forms"): every row
    # from the generic arrays, or spheres' rows in body form instead of compact
    ("moreau-jean generic rows", ["--scheme", "moreau-jean", "--row-storage", "generic"]),
    ("moreau-jean body-form rows", ["--scheme", "moreau-jean", "--row-storage", "body-form"]),
    ("catching-up generic rows", ["--scheme", "catching-up", "--row-storage", "generic"]),
    ("catching-up body-form rows", ["--scheme", "catching-up", "--row-storage", "body-form"]),
]


def percentile95(values):
    values = sorted(values)
    return values[int(0.95 * len(values))] if values else 0


def run(sweep, scene, options, out_dir):
    command = [sweep, "run", os.path.join(ROOT, scene), "--out", out_dir, "--quiet",
               "--set", "output.vtk_interval=0", "--set", "output.stats=true"] + options
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    with open(os.path.join(out_dir, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(out_dir, "stats.csv")) as f:
        rows = list(csv.DictReader(f))
    stage1 = [int(r["iterations_stage1"]) for r in rows]
    stage2 = [int(r["iterations_stage2"]) for r in rows]
    return {
        "cpu_seconds": summary["cpu_seconds"],
        "solve_seconds": sum(float(r["t_solve"]) for r in rows),
        "stage1_p95": percentile95(stage1),
        "stage2_p95": percentile95(stage2),
        "stage1_max": max(stage1, default=0),
        "stage2_max": max(stage2, default=0),
        "cap_hit_steps": sum(int(r["cap_hit"]) for r in rows),
        "penetration_cumulative": summary["penetration"]["cumulative"],
        "steps": len(rows),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="results/stage_solvers")
    parser.add_argument("--sweep", default=os.path.join(ROOT, "build", "sweep"))
    parser.add_argument("--cases", default="funnel,slider_crank,funnel_500")
    parser.add_argument("--configs", default=",".join(name for name, _ in CONFIGS[:4]),
                        help="comma-separated configurations, of: " +
                        ", ".join(name for name, _ in CONFIGS))
    parser.add_argument("--dt", default="", help="time steps for the funnel cases (default: the "
                        "scene's)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="runs per point, the configurations alternating; the least CPU "
                        "time is kept (the machines are shared)")
    parser.add_argument("extra", nargs="*", help="options passed to every sweep run")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    configs = [(name, options) for name, options in CONFIGS
               if name in args.configs.split(",")]
    results = []
    for case in args.cases.split(","):
        scene, extra = CASES[case]
        steps = [None]
        if args.dt and case.startswith("funnel"):
            steps = args.dt.split(",")
        for dt in steps:
            best = {}
            for _ in range(args.repeat):
                for name, options in configs:
                    label = f"{case}_{name.replace(' ', '_')}" + (f"_dt{dt}" if dt else "")
                    opts = extra + options + (["--dt", dt] if dt else []) + args.extra
                    row = run(args.sweep, scene, opts, os.path.join(args.out, "runs", label))
                    if name not in best or row["cpu_seconds"] < best[name]["cpu_seconds"]:
                        best[name] = row
            for name, _ in configs:
                row = best[name]
                row.update({"case": case, "dt": dt or "scene", "config": name})
                results.append(row)
                print(f"{case} {dt or ''} {name}: cpu {row['cpu_seconds']:.3f} s, p95 "
                      f"{row['stage1_p95']} / {row['stage2_p95']}, caps {row['cap_hit_steps']}",
                      flush=True)
    fields = ["case", "dt", "config", "steps", "cpu_seconds", "solve_seconds", "stage1_p95",
              "stage2_p95", "stage1_max", "stage2_max", "cap_hit_steps", "penetration_cumulative"]
    with open(os.path.join(args.out, "stage_solvers.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(results)
    print("\n| case | h | configuration | CPU (s) | solve (s) | p95 5a (A: coupled) / 5b | max 5a / 5b"
          " | cap-hit steps | cumulative penetration (m) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in results:
        print(f"| {r['case']} | {r['dt']} | {r['config']} | {r['cpu_seconds']:.3f} | "
              f"{r['solve_seconds']:.3f} | {r['stage1_p95']} / {r['stage2_p95']} | "
              f"{r['stage1_max']} / {r['stage2_max']} | {r['cap_hit_steps']} | "
              f"{r['penetration_cumulative']:.3g} |")


if __name__ == "__main__":
    main()
