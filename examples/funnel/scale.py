#!/usr/bin/env python3
"""Scale study of the Hall funnel (issue #6, docs/funnel.md): the same 60-degree funnel with
more disks and a wider orifice (D grows as sqrt(N / 50), so the lattice keeps its aspect),
run by `sweep run` for a fixed number of steps. Writes OUT/scale.csv (one row per run),
OUT/scale.png (CPU time per step against mean active contacts, log-log, with the fitted
slope per scheme) and prints the slopes.

  /usr/bin/python3 examples/funnel/scale.py --out results/funnel_scale \
      --counts 500,5000,50000 --schemes catching-up \
      -- --set scheme.normal_law=pos --set scheme.tangents=local

Everything after `--` goes to every `sweep run` (flags of the comparison).
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from least_squares import log_log_slope  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="results/funnel_scale")
    parser.add_argument("--sweep", default=os.path.join(ROOT, "build", "sweep"))
    parser.add_argument("--scene", default=os.path.join(ROOT, "examples", "funnel", "funnel.yaml"))
    parser.add_argument("--counts", default="500,5000,50000")
    parser.add_argument("--schemes", default="catching-up")
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--dt", type=float, default=1e-4)
    parser.add_argument("--reuse", action="store_true",
                        help="analyse the runs already in OUT, skip the missing ones")
    parser.add_argument("extra", nargs="*", help="options passed to every sweep run")
    args = parser.parse_args()

    os.makedirs(args.out, exist_ok=True)
    rows = []
    for scheme in args.schemes.split(","):
        for count in [int(c) for c in args.counts.split(",")]:
            orifice = 2.54e-3 * math.sqrt(count / 50.0)
            run_dir = os.path.join(args.out, f"{scheme}_N{count}")
            command = [args.sweep, "run", args.scene, "--scheme", scheme, "--dt", repr(args.dt),
                       "--t-end", repr(args.steps * args.dt), "--out", run_dir, "--quiet",
                       "--set", f"generators[0].count={count}",
                       "--set", f"generators[0].orifice={orifice!r}",
                       "--set", "output.vtk_interval=0"] + args.extra
            if args.reuse:
                if not os.path.exists(os.path.join(run_dir, "summary.json")):
                    continue
            else:
                print(" ".join(command), flush=True)
                subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
            with open(os.path.join(run_dir, "summary.json")) as f:
                s = json.load(f)
            steps = s["steps"]
            rows.append({
                "scheme": scheme, "count": count, "orifice": orifice, "steps": steps,
                "cpu_seconds": s["cpu_seconds"],
                "cpu_per_step": s["cpu_seconds"] / steps,
                "mean_active": s["contacts"]["mean_active"],
                "max_active": s["contacts"]["max_active"],
                "iterations_mean": s["iterations"]["mean"],
                "stage1_p95": s["iterations"]["stage1"]["p95"],
                "stage2_p95": s["iterations"]["stage2"]["p95"],
                "cap_hit_steps": s["iterations"]["cap_hit_steps"],
                "ns_per_update": s["solver"]["ns_per_update"],
                "solve_fraction": s["solver"]["solve_seconds"] / s["cpu_seconds"],
                "cumulative_penetration": s["penetration"]["cumulative"],
                "peak_penetration": s["penetration"]["peak"],
            })
            print(f"  {scheme} N={count}: {rows[-1]['cpu_seconds']:.3g} s, "
                  f"{rows[-1]['mean_active']:.0f} contacts, "
                  f"{rows[-1]['iterations_mean']:.0f} sweeps/step", flush=True)

    with open(os.path.join(args.out, "scale.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)

    slopes = {}
    for scheme in args.schemes.split(","):
        mine = [r for r in rows if r["scheme"] == scheme]
        if len(mine) >= 2:
            slopes[scheme] = {
                "cpu_per_step": log_log_slope([r["mean_active"] for r in mine],
                                          [r["cpu_per_step"] for r in mine]),
                # cost per sweep and contact: what the slope would be without the growth of
                # the sweep count with the depth of the pile
                "cpu_per_sweep": log_log_slope(
                    [r["mean_active"] for r in mine],
                    [r["cpu_per_step"] / max(r["iterations_mean"], 1.0) for r in mine]),
            }
            print(f"{scheme}: log-log slope of CPU per step against contacts "
                  f"{slopes[scheme]['cpu_per_step']:.2f}; per sweep "
                  f"{slopes[scheme]['cpu_per_sweep']:.2f}")
    with open(os.path.join(args.out, "slopes.json"), "w") as f:
        json.dump(slopes, f, indent=1)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for scheme in args.schemes.split(","):
        mine = [r for r in rows if r["scheme"] == scheme]
        label = scheme
        if scheme in slopes:
            label += f" (slope {slopes[scheme]['cpu_per_step']:.2f})"
        ax.loglog([r["mean_active"] for r in mine], [r["cpu_per_step"] for r in mine], "o-",
                  label=label)
        for r in mine:
            ax.annotate(f"N={r['count']}", (r["mean_active"], r["cpu_per_step"]),
                        textcoords="offset points", xytext=(4, -10), fontsize=8)
    x0 = min(r["mean_active"] for r in rows)
    x1 = max(r["mean_active"] for r in rows)
    y0 = min(r["cpu_per_step"] for r in rows if r["mean_active"] == x0)
    ax.loglog([x0, x1], [y0, y0 * x1 / x0], "k:", label="slope 1")
    ax.set_xlabel("mean active contacts")
    ax.set_ylabel("CPU time per step (s)")
    ax.set_title(f"Hall funnel, h = {args.dt:g}, {args.steps} steps")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "scale.png"), dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
