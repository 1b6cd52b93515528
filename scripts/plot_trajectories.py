#!/usr/bin/python3
"""Trajectory figures of the validation cases: the two schemes against the event-driven
reference, one PNG per case with three panels (coordinates, energy, normal impulses per
sample). Reads the CSV of bench/validation_trajectories
(case,source,t,x1,x2,energy,impulse). Usage:
  plot_trajectories.py TRAJECTORIES.csv OUT_DIR
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LABELS = {
    "V1_bouncing_ball": ("centre height z (m)", "vertical velocity (m/s)"),
    "V10_wall_pendulum": ("th1 (rad)", "th2 (rad)"),
    "V9_woodpecker": ("sleeve height y (m)", "bird angle phi_S (rad)"),
    "V11_slider_crank": ("crank rate (rad/s)", "slider centre height (m)"),
    "V3_ramp_force": ("displacement x (m)", "speed (m/s)"),
    "V5_rocking_block": ("tilt angle (rad)", "angular velocity (rad/s)"),
    "V7_painleve_rod": ("sliding speed of the lower end (m/s)", "rod angle (rad)"),
}
# cases whose second coordinate goes on a twin axis (different units or scale)
TWIN = {"V1_bouncing_ball", "V9_woodpecker", "V11_slider_crank", "V3_ramp_force",
        "V5_rocking_block", "V7_painleve_rod"}
STYLES = {
    "reference": ("k-", "event-driven reference", 2.0),
    "moreau-jean": ("C0--", "Jean-Moreau", 1.2),
    "catching-up": ("C1:", "staggered", 1.2),
}


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    with open(argv[1]) as f:
        rows = list(csv.DictReader(f))
    os.makedirs(argv[2], exist_ok=True)
    for case in sorted({r["case"] for r in rows}):
        fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.0), sharex=True)
        twins = {}
        first, second = LABELS.get(case, ("x1", "x2"))
        for source, (style, label, width) in STYLES.items():
            mine = [r for r in rows if r["case"] == case and r["source"] == source]
            if not mine:
                continue
            t = [float(r["t"]) for r in mine]
            axes[0].plot(t, [float(r["x1"]) for r in mine], style, lw=width, label=f"{label}: {first}")
            if case in TWIN and case != "V1_bouncing_ball":
                if case not in twins:  # one twin axis per figure
                    twins[case] = axes[0].twinx()
                twin = twins[case]
                twin.plot(t, [float(r["x2"]) for r in mine], style[2:], lw=width * 0.6, alpha=0.5,
                          color="C2" if source == "moreau-jean" else "C3")
                twin.set_ylabel(second)
            if case == "V10_wall_pendulum":
                axes[0].plot(t, [float(r["x2"]) for r in mine], style, lw=width * 0.7, alpha=0.6,
                             label=f"{label}: {second}")
            if all(r["energy"] for r in mine):  # an exact reference may have none
                axes[1].plot(t, [float(r["energy"]) for r in mine], style, lw=width, label=label)
            if source != "reference":
                axes[2].plot(t, [float(r["impulse"]) for r in mine], style, lw=width, label=label)
        axes[0].set_ylabel(first if case != "V10_wall_pendulum" else "absolute angles (rad)")
        axes[1].set_ylabel("energy (J)")
        axes[2].set_ylabel("normal impulse per sample (N s)")
        axes[2].set_xlabel("t (s)")
        for ax in axes:
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7, loc="best")
        axes[0].set_title(case.replace("_", " "))
        fig.tight_layout()
        fig.savefig(os.path.join(argv[2], f"{case}_trajectory.png"), dpi=110)
        plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
