#!/usr/bin/python3
"""The Hall funnel from Python: both schemes stepped side by side, the disks at the end and
the iterations per step in one matplotlib figure. From a built tree:

  PYTHONPATH=build/python /usr/bin/python3 examples/python/funnel.py results/funnel_python.png [T_END]
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

import sweep  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = os.path.join(ROOT, "examples", "funnel", "funnel.yaml")


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "funnel_python.png"
    t_end = float(sys.argv[2]) if len(sys.argv) > 2 else 0.06
    figure, axes = plt.subplots(1, 3, figsize=(13, 4.5),
                                gridspec_kw={"width_ratios": [1, 1, 1.4]})
    for ax, scheme in zip(axes[:2], ("moreau-jean", "catching-up")):
        sim = sweep.Simulation(SCENE, scheme=scheme)
        iterations = []
        sim.run(t_end=t_end, callback=lambda s: iterations.append(
            s.last_step["iterations_stage1"] + s.last_step["iterations_stage2"]))
        for shape in sim.shapes():
            if shape["type"] == "disk":
                x, y, _ = shape["position"]
                ax.add_patch(Circle((x, y), shape["radius"], facecolor="tab:orange",
                                    edgecolor="k", lw=0.3))
            elif shape["type"] == "segment":
                ax.plot([shape["start"][0], shape["end"][0]],
                        [shape["start"][1], shape["end"][1]], "k-", lw=1)
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_title(f"{scheme}, t = {sim.t:.3f} s")
        axes[2].plot(iterations, lw=0.8, label=scheme)
    axes[2].set_xlabel("step")
    axes[2].set_ylabel("iterations per step (both stages)")
    axes[2].set_yscale("symlog")
    axes[2].legend()
    figure.tight_layout()
    figure.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
