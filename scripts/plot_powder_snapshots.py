#!/usr/bin/python3
"""Side views of a powder-bed run (x along the spreading direction, y up), one panel per time,
from the run's VTK series (`sweep run` with output.vtk_interval). Spheres are filled circles of
their true radius coloured by speed, drawn from the back of the periodic width to the front;
the blade, gate and fence (boxes) are grey, the roller (a line with a radius) a grey band.
Usage:
  plot_powder_snapshots.py OUT.png --times T1,T2,... RUN_DIR [--x-max X] [--y-max Y]
"""
import argparse
import os
import sys
import xml.etree.ElementTree as ET

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PatchCollection, PolyCollection  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_snapshots import series, vtp_cells  # noqa: E402


def load(path):
    """Spheres as (x, y, z, radius, speed), box faces and roller lines as lists of points."""
    piece = ET.parse(path).getroot().find("./PolyData/Piece")
    arrays = {a.get("Name"): (a.text or "").split() for a in piece.findall("./PointData/DataArray")}
    xyz = [float(x) for x in piece.find("./Points/DataArray").text.split()]
    points = [tuple(xyz[3 * i:3 * i + 3]) for i in range(len(xyz) // 3)]
    radius = [float(r) for r in arrays["radius"]]
    velocity = [float(x) for x in arrays["velocity"]]

    def cells(tag):
        return vtp_cells(piece, tag)

    spheres = []
    for c in cells("Verts"):
        i = c[0]
        speed = sum(velocity[3 * i + k] ** 2 for k in range(3)) ** 0.5
        spheres.append((*points[i], radius[i], speed))
    faces = [[points[i][:2] for i in c] for c in cells("Polys")]
    rods = [([points[i][:2] for i in c], radius[c[0]]) for c in cells("Lines")]
    return spheres, faces, rods


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--times", required=True)
    parser.add_argument("run")
    parser.add_argument("--x-max", type=float, default=None, help="right edge of the view (m)")
    parser.add_argument("--y-max", type=float, default=0.8e-3, help="top of the view (m)")
    parser.add_argument("--v-max", type=float, default=0.2, help="top of the speed colour scale")
    args = parser.parse_args(argv[1:])
    snapshots = series(args.run)
    if not snapshots:
        sys.exit(f"plot_powder_snapshots.py: {args.run}/snapshots.pvd lists no snapshots")
    times = [float(t) for t in args.times.split(",")]
    x_view = args.x_max or 6e-3
    panel = 8.0 * (args.y_max / x_view) + 0.45  # inches: equal aspect in a 10-inch figure
    fig, axes = plt.subplots(len(times), 1, figsize=(10, panel * len(times) + 0.3), squeeze=False,
                             layout="constrained")
    norm = plt.Normalize(0.0, args.v_max)
    mappable = None
    for ax, t in zip(axes[:, 0], times):
        time, path = min(snapshots, key=lambda s: abs(s[0] - t))
        spheres, faces, rods = load(path)
        spheres.sort(key=lambda s: s[2])  # back of the width first
        x_max = args.x_max or max(s[0] + s[3] for s in spheres)
        ax.add_collection(PolyCollection(faces, facecolor="0.75", edgecolor="0.4", lw=0.5))
        for line, r in rods:
            ax.add_collection(PatchCollection([Circle(p, r) for p in line[:1]], facecolor="0.75",
                                              edgecolor="0.4", lw=0.5))
        mappable = PatchCollection([Circle((s[0], s[1]), s[3]) for s in spheres], cmap="viridis",
                                   norm=norm, edgecolor="k", lw=0.1)
        mappable.set_array([s[4] for s in spheres])
        ax.add_collection(mappable)
        ax.axhline(0.0, color="k", lw=1.0)
        ax.set_xlim(0.0, x_max)
        ax.set_ylim(-0.02e-3, args.y_max)
        ax.set_aspect("equal")
        ax.set_title(f"t = {1e3 * time:.1f} ms", fontsize=9, loc="left")
        ax.set_xticks([k * 1e-3 for k in range(int(x_max * 1e3) + 1)])
        ax.set_xticklabels([f"{k} mm" for k in range(int(x_max * 1e3) + 1)], fontsize=7)
        ax.set_yticks([])
    fig.colorbar(mappable, ax=axes[:, 0].tolist(), label="speed (m/s)", shrink=0.8)
    fig.savefig(args.out + ".partial.png", dpi=150)
    os.replace(args.out + ".partial.png", args.out)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
