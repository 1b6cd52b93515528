#!/usr/bin/python3
"""Convergence plots of the validation cases: error against h, log-log, one PNG per case,
both schemes, with the least-squares order in the legend. Reads the CSV of
bench/validation_convergence (case,scheme,h,error,order). Usage:
  plot_convergence.py CONVERGENCE.csv OUT_DIR
"""
import csv
import os
import sys

from least_squares import log_log_slope

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MARKERS = {"moreau-jean": ("o-", "Jean-Moreau"), "catching-up": ("s--", "staggered")}


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    with open(argv[1]) as f:
        rows = list(csv.DictReader(f))
    os.makedirs(argv[2], exist_ok=True)
    for case in sorted({r["case"] for r in rows}):
        fig, ax = plt.subplots(figsize=(5.5, 4.2))
        for scheme, (style, label) in MARKERS.items():
            mine = [r for r in rows if r["case"] == case and r["scheme"] == scheme]
            if not mine:
                continue
            hs = [float(r["h"]) for r in mine]
            errors = [float(r["error"]) for r in mine]
            ax.loglog(hs, errors, style, label=f"{label} (order {log_log_slope(hs, errors):.2f})",
                      markersize=6 if scheme == "moreau-jean" else 4)
        hs = sorted({float(r["h"]) for r in rows if r["case"] == case})
        top = max(float(r["error"]) for r in rows if r["case"] == case)
        ax.loglog(hs, [top * h / hs[-1] for h in hs], "k:", label="order 1")
        ax.set_xlabel("h (s)")
        ax.set_ylabel("error")
        ax.set_title(case.replace("_", " "))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(os.path.join(argv[2], f"{case}_convergence.png"), dpi=120)
        plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
