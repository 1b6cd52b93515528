#!/usr/bin/env python3
"""Discharge of the Hall funnel against the 2D Beverloo law (issue #6, docs/funnel.md).

For each orifice width D = ratio * d (d the mean disk diameter), `sweep run` fills the
funnel, pulls the shutter and lets it drain; the discharged mass M(t) is read from the VTK
snapshots (disks whose centre is more than one diameter below the orifice). The steady rate
W is the slope of M(t) between 20 % and 60 % of the final discharged mass; the same slope
over the first and second halves of that window tests that the rate does not depend on the
fill height. The rates are fitted to

    W = C rho sqrt(g) (D - k d)^b          (rho: solid density per unit thickness)

by least squares in log space over a grid of k (b and C follow by linear regression).
Writes OUT/discharge.csv, OUT/beverloo.json and OUT/beverloo.png.

  /usr/bin/python3 examples/funnel/discharge.py --out results/funnel_discharge \
      --ratios 4,6,8,12,16 --count 2000 -- --set scheme.normal_law=pos
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
from least_squares import slope  # noqa: E402
from plot_snapshots import load, series  # noqa: E402


def discharge_curve(run_dir, density):
    """(t, discharged mass per unit thickness, mass in the funnel) for each snapshot."""
    curve = []
    for t, path in series(run_dir):
        disks, _, _ = load(path)
        out = inside = 0.0
        for (x, y), r in disks:
            if r <= 0.0:
                continue
            m = density * math.pi * r * r
            if y < -2.0 * r:
                out += m
            else:
                inside += m
        curve.append((t, out, inside))
    return curve


def steady_rate(curve):
    """Slope of M(t) where 20-60 % of the final discharge has left, and over each half."""
    final = curve[-1][1]
    window = [(t, m) for t, m, _ in curve if 0.2 * final <= m <= 0.6 * final]
    if len(window) < 6 or final <= 0.0:
        return None
    half = len(window) // 2
    ts, ms = zip(*window)
    return (slope(ts, ms), slope(ts[:half], ms[:half]), slope(ts[half:], ms[half:]),
            window[0][0], window[-1][0])


def fit_beverloo(D, W, d, exponent=None):
    """Best (k, b, A, sse) of W = A (D - k d)^b over k in [0, 3] (step 0.005); b is fitted,
    or held at `exponent`."""
    best = None
    for i in range(0, 601):
        k = 0.005 * i
        if min(D) - k * d <= 0.0:
            break
        x = [math.log(Di - k * d) for Di in D]
        y = [math.log(Wi) for Wi in W]
        b = slope(x, y) if exponent is None else exponent
        a = sum(y) / len(y) - b * sum(x) / len(x)
        sse = sum((yi - (a + b * xi)) ** 2 for xi, yi in zip(x, y))
        if best is None or sse < best[3]:
            best = (k, b, math.exp(a), sse)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="results/funnel_discharge")
    parser.add_argument("--sweep", default=os.path.join(ROOT, "build", "sweep"))
    parser.add_argument("--scene", default=os.path.join(ROOT, "examples", "funnel", "funnel.yaml"))
    parser.add_argument("--ratios", default="4,6,8,12,16")
    parser.add_argument("--count", type=int, default=2000)
    parser.add_argument("--t-end", type=float, default=0.4)
    parser.add_argument("--shutter", type=float, default=0.05)
    parser.add_argument("--interval", type=float, default=0.004, help="snapshot interval (s)")
    parser.add_argument("--scheme", default="catching-up")
    parser.add_argument("--radius", type=float, default=0.3e-3, help="mean disk radius (m)")
    parser.add_argument("--density", type=float, default=7800.0)
    parser.add_argument("--gravity", type=float, default=9.81)
    parser.add_argument("--reuse", action="store_true", help="analyse existing runs only")
    parser.add_argument("extra", nargs="*", help="options passed to every sweep run")
    args = parser.parse_args()

    d = 2.0 * args.radius
    os.makedirs(args.out, exist_ok=True)
    rows, curves = [], {}
    for ratio in [float(r) for r in args.ratios.split(",")]:
        D = ratio * d
        run_dir = os.path.join(args.out, f"D{ratio:g}d")
        if not args.reuse:
            command = [args.sweep, "run", args.scene, "--scheme", args.scheme,
                       "--t-end", repr(args.t_end), "--out", run_dir, "--quiet",
                       "--set", f"generators[0].count={args.count}",
                       "--set", f"generators[0].orifice={D!r}",
                       "--set", f"generators[0].shutter_time={args.shutter!r}",
                       "--set", f"output.vtk_interval={args.interval!r}"] + args.extra
            print(" ".join(command), flush=True)
            subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
        curve = discharge_curve(run_dir, args.density)
        curves[ratio] = curve
        rate = steady_rate(curve)
        row = {"ratio": ratio, "D": D, "discharged_fraction": curve[-1][1] /
               (curve[-1][1] + curve[-1][2]), "rate": "", "rate_first_half": "",
               "rate_second_half": "", "window_start": "", "window_end": ""}
        if rate is not None:
            row.update(rate=rate[0], rate_first_half=rate[1], rate_second_half=rate[2],
                       window_start=rate[3], window_end=rate[4])
            print(f"  D/d = {ratio:g}: W = {rate[0]:.4g} kg/(m s), halves {rate[1]:.4g} / "
                  f"{rate[2]:.4g}, window {rate[3]:.3f}-{rate[4]:.3f} s", flush=True)
        else:
            print(f"  D/d = {ratio:g}: no steady window (jammed or too short); discharged "
                  f"{row['discharged_fraction']:.0%}", flush=True)
        rows.append(row)

    with open(os.path.join(args.out, "discharge.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)

    good = [r for r in rows if r["rate"] != ""]
    result = {"d": d, "rows_used": len(good)}
    if len(good) >= 3:
        k, b, A, sse = fit_beverloo([r["D"] for r in good], [r["rate"] for r in good], d)
        C = A / (args.density * math.sqrt(args.gravity))
        result.update(k=k, exponent=b, C_solid_density=C, log_rms=math.sqrt(sse / len(good)),
                      exponent_ok=abs(b - 1.5) <= 0.2, k_ok=0.5 <= k <= 2.5,
                      halves_ratio=[r["rate_second_half"] / r["rate_first_half"] for r in good])
        print(f"Beverloo fit: exponent {b:.3f} (target 1.5 +- 0.2), k {k:.3f} (target "
              f"[0.5, 2.5]), C {C:.3f} (with the solid density), log rms {result['log_rms']:.3f}")
        # the same data with the exponent held at 3/2: how much worse the fit is says how
        # well the data pin the exponent down
        k15, _, A15, sse15 = fit_beverloo([r["D"] for r in good], [r["rate"] for r in good], d,
                                          exponent=1.5)
        result.update(k_at_exponent_1_5=k15,
                      C_at_exponent_1_5=A15 / (args.density * math.sqrt(args.gravity)),
                      log_rms_at_exponent_1_5=math.sqrt(sse15 / len(good)))
        print(f"  with the exponent held at 1.5: k {k15:.3f}, log rms "
              f"{result['log_rms_at_exponent_1_5']:.3f}")
    with open(os.path.join(args.out, "beverloo.json"), "w") as f:
        json.dump(result, f, indent=1)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
    for ratio, curve in curves.items():
        left.plot([c[0] for c in curve], [c[1] for c in curve], label=f"D/d = {ratio:g}")
    left.axvline(args.shutter, color="k", ls=":", lw=0.8)
    left.set_xlabel("t (s)")
    left.set_ylabel("discharged mass per unit thickness (kg/m)")
    left.legend()
    left.grid(alpha=0.3)
    if len(good) >= 3:
        Ds = [r["D"] for r in good]
        right.plot([D / d for D in Ds], [r["rate"] for r in good], "o", label="measured")
        lo, hi = min(Ds), max(Ds)
        xs = [lo + (hi - lo) * i / 100 for i in range(101)]
        right.plot([x / d for x in xs], [A * (x - k * d) ** b for x in xs], "-",
                   label=f"fit: (D - {k:.2f} d)^{b:.2f}")
        k15 = result["k_at_exponent_1_5"]
        A15 = result["C_at_exponent_1_5"] * args.density * math.sqrt(args.gravity)
        right.plot([x / d for x in xs], [A15 * (x - k15 * d) ** 1.5 for x in xs], ":",
                   label=f"exponent held at 1.5: (D - {k15:.2f} d)^1.5")
        right.set_xscale("log")
        right.set_yscale("log")
    right.set_xlabel("D / d")
    right.set_ylabel("steady discharge rate W (kg/(m s))")
    right.legend()
    right.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "beverloo.png"), dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
