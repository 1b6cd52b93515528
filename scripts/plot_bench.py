#!/usr/bin/python3
"""Figures of `sweep bench DIR`: run time and penetration against the time step, the
run-time-against-penetration (Pareto) view with the speed-up at equal penetration, and the
solver iterations per step (NLGS sweeps, or the convex stage solvers' iterations). Reads
DIR/bench.csv and DIR/runs/*/stats.csv; writes PNGs and DIR/speedup.csv.
Usage: plot_bench.py DIR [--iterations-dt H]
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {
    "moreau-jean": dict(color="tab:red", marker="o", label="Jean-Moreau"),
    "catching-up": dict(color="tab:blue", marker="s", label="staggered (catching-up)"),
}


def read_bench(folder):
    rows = {}
    with open(os.path.join(folder, "bench.csv")) as f:
        for r in csv.DictReader(f):
            rows.setdefault(r["scheme"], []).append(
                {k: (v if k == "scheme" else float(v)) for k, v in r.items()})
    for scheme in rows:
        rows[scheme].sort(key=lambda r: r["dt"])
    return rows


def loglog_interpolate(xs, ys, x):
    """y at x on the piecewise log-log line through (xs, ys); None outside the range."""
    points = sorted((a, b) for a, b in zip(xs, ys) if a > 0 and b > 0)
    for (x0, y0), (x1, y1) in zip(points, points[1:]):
        if min(x0, x1) <= x <= max(x0, x1) and x0 != x1:
            s = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
            return math.exp(math.log(y0) + s * (math.log(y1) - math.log(y0)))
    return None


def speedups(rows, slow="moreau-jean", fast="catching-up"):
    """For each point of the fast scheme, the slow scheme's CPU time at the same cumulative
    penetration (log-log interpolation along the slow scheme's curve) over the fast one's."""
    out = []
    if slow not in rows or fast not in rows:
        return out
    pen_slow = [r["penetration_cumulative"] for r in rows[slow]]
    cpu_slow = [r["cpu_seconds"] for r in rows[slow]]
    for r in rows[fast]:
        cpu = loglog_interpolate(pen_slow, cpu_slow, r["penetration_cumulative"])
        if cpu is not None and r["cpu_seconds"] > 0:
            out.append((r["dt"], r["penetration_cumulative"], r["cpu_seconds"], cpu,
                        cpu / r["cpu_seconds"]))
    return out


def plot_vs_dt(rows, folder):
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for scheme, rs in rows.items():
        style = STYLE.get(scheme, dict(label=scheme))
        dts = [r["dt"] for r in rs]
        a.loglog(dts, [r["cpu_seconds"] for r in rs], **style)
        positive = [(r["dt"], r["penetration_cumulative"]) for r in rs
                    if r["penetration_cumulative"] > 0]
        if positive:
            b.loglog(*zip(*positive), **style)
    a.set_xlabel("time step h (s)")
    a.set_ylabel("CPU time (s)")
    b.set_xlabel("time step h (s)")
    b.set_ylabel("cumulative penetration (m)")
    for ax in (a, b):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "cpu_and_penetration_vs_dt.png"), dpi=120)
    plt.close(fig)


def plot_pareto(rows, folder, gains):
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for scheme, rs in rows.items():
        style = STYLE.get(scheme, dict(label=scheme))
        pts = [(r["penetration_cumulative"], r["cpu_seconds"]) for r in rs
               if r["penetration_cumulative"] > 0]
        if pts:
            ax.loglog(*zip(*pts), **style)
    if gains:
        # the caption states the whole range; the arrow marks the largest gain
        best = max(gains, key=lambda g: g[4])
        worst = min(gains, key=lambda g: g[4])
        ax.set_title(f"staggered / Jean-Moreau at equal penetration: {worst[4]:.3g}x\n"
                     f"(h = {worst[0]:g}) to {best[4]:.3g}x (h = {best[0]:g}, the arrow)",
                     fontsize=9)
        ax.annotate("", xy=(best[1], best[2]), xytext=(best[1], best[3]),
                    arrowprops=dict(arrowstyle="<->"))
    ax.set_xlabel("cumulative penetration (m)")
    ax.set_ylabel("CPU time (s)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "cpu_vs_penetration.png"), dpi=120)
    plt.close(fig)


def read_stats(path):
    with open(path) as f:
        return [{k: float(v) for k, v in r.items() if k != "status"} for r in csv.DictReader(f)]


def plot_iterations(rows, folder, wanted_dt):
    dts = sorted({r["dt"] for rs in rows.values() for r in rs})
    if not dts:
        return
    dt = min(dts, key=lambda d: abs(math.log(d / wanted_dt)))
    fig, ax = plt.subplots(figsize=(8, 4))
    for scheme in rows:
        run = os.path.join(folder, "runs", f"{scheme}_dt{dt:g}", "stats.csv")
        if not os.path.exists(run):
            continue
        stats = read_stats(run)
        t = [s["t"] for s in stats]
        style = STYLE.get(scheme, dict(label=scheme))
        if scheme == "catching-up":
            ax.plot(t, [s["iterations_stage1"] for s in stats], color=style["color"], lw=0.8,
                    label=style["label"] + ", stage 1 (shock)")
            ax.plot(t, [s["iterations_stage2"] for s in stats], color="tab:cyan", lw=0.8,
                    label=style["label"] + ", stage 2 (friction)")
        else:
            ax.plot(t, [s["iterations_stage1"] + s["iterations_stage2"] for s in stats],
                    color=style.get("color"), lw=0.8, label=style["label"])
    ax.set_yscale("symlog", linthresh=10)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("solver iterations per step")
    ax.set_title(f"h = {dt:g} s")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "iterations_per_step.png"), dpi=120)
    plt.close(fig)


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder = argv[1]
    wanted_dt = float(argv[argv.index("--iterations-dt") + 1]) if "--iterations-dt" in argv else 1e-4
    rows = read_bench(folder)
    gains = speedups(rows)
    with open(os.path.join(folder, "speedup.csv.partial"), "w") as f:
        f.write("dt,penetration_cumulative,cpu_catching_up,cpu_moreau_jean_interpolated,speedup\n")
        for g in gains:
            f.write(",".join(f"{x:.9g}" for x in g) + "\n")
    os.replace(os.path.join(folder, "speedup.csv.partial"), os.path.join(folder, "speedup.csv"))
    plot_vs_dt(rows, folder)
    plot_pareto(rows, folder, gains)
    plot_iterations(rows, folder, wanted_dt)
    for g in gains:
        print(f"h = {g[0]:g}: speed-up at equal penetration {g[4]:.3g}x")
    if not gains:
        print("no speed-up at equal penetration: the penetration ranges do not overlap")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
