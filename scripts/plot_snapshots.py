#!/usr/bin/python3
"""Snapshots of 2D runs side by side (the seed's Figure 1): disks as circles coloured by
penetration-free scheme colour, walls and the shutter as lines, read from each run's VTK
series (`sweep run` with output.vtk_interval). Usage:
  plot_snapshots.py OUT.png --times T1,T2,T3 RUN_DIR[:LABEL] [RUN_DIR[:LABEL] ...]
"""
import os
import sys
import xml.etree.ElementTree as ET

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import LineCollection, PatchCollection  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

COLOURS = ["tab:red", "tab:blue", "tab:green", "tab:purple"]


def series(run_dir):
    root = ET.parse(os.path.join(run_dir, "snapshots.pvd")).getroot()
    return [(float(d.get("timestep")), os.path.join(run_dir, d.get("file")))
            for d in root.findall("./Collection/DataSet")]


def vtp_cells(piece, tag):
    """The point indices of each cell of a VTK PolyData piece's Verts, Lines or Polys."""
    block = piece.find(f"./{tag}")
    if block is None:
        return []
    conn = [int(x) for x in (block.find("./DataArray[@Name='connectivity']").text or "").split()]
    offs = [int(x) for x in (block.find("./DataArray[@Name='offsets']").text or "").split()]
    out, start = [], 0
    for end in offs:
        out.append(conn[start:end])
        start = end
    return out


def load(path):
    piece = ET.parse(path).getroot().find("./PolyData/Piece")
    arrays = {a.get("Name"): a.text.split() for a in piece.findall("./PointData/DataArray")}
    xyz = [float(x) for x in piece.find("./Points/DataArray").text.split()]
    points = [(xyz[3 * i], xyz[3 * i + 1]) for i in range(len(xyz) // 3)]

    def cells(tag):
        return vtp_cells(piece, tag)

    radius = [float(r) for r in arrays["radius"]]
    disks = [(points[c[0]], radius[c[0]]) for c in cells("Verts")]
    lines = [[points[i] for i in c] for c in cells("Lines")]
    polys = [[points[i] for i in c] for c in cells("Polys")]
    return disks, lines, polys


def nearest(snapshots, t):
    return min(snapshots, key=lambda s: abs(s[0] - t))


def main(argv):
    if len(argv) < 5 or argv[2] != "--times":
        print(__doc__, file=sys.stderr)
        return 2
    out, times = argv[1], [float(t) for t in argv[3].split(",")]
    runs = []
    for spec in argv[4:]:
        folder, _, label = spec.partition(":")
        runs.append((series(folder), label or os.path.basename(folder.rstrip("/"))))
    fig, axes = plt.subplots(1, len(times), figsize=(4 * len(times), 4.6), squeeze=False)
    # one frame for every panel: everything drawn at the times shown, walls and grains
    frames = [[(label, k) + nearest(snaps, t) for k, (snaps, label) in enumerate(runs)]
              for t in times]
    xs, ys = [], []
    for panel in frames:
        for _, _, _, path in panel:
            disks, lines, polys = load(path)
            for c, r in disks:
                xs += [c[0] - r, c[0] + r]
                ys += [c[1] - r, c[1] + r]
            for seg in lines + polys:
                xs += [p[0] for p in seg]
                ys += [p[1] for p in seg]
    bounds = None
    if xs:
        pad = 0.05 * max(max(xs) - min(xs), max(ys) - min(ys))
        bounds = (min(xs) - pad, max(xs) + pad, min(ys) - pad, max(ys) + pad)
    for ax, panel in zip(axes[0], frames):
        for label, k, time, path in panel:
            disks, lines, polys = load(path)
            colour = COLOURS[k % len(COLOURS)]
            ax.add_collection(PatchCollection([Circle(c, r) for c, r in disks], facecolor="none",
                                              edgecolor=colour, lw=0.8, label=label))
            ax.add_collection(LineCollection(lines + polys, colors="k", lw=1.5))
        ax.set_title(f"t = {time:.3f} s")
        ax.set_aspect("equal")
        if bounds:
            ax.set_xlim(bounds[0], bounds[1])
            ax.set_ylim(bounds[2], bounds[3])
        ax.set_xticks([])
        ax.set_yticks([])
    handles = [plt.Line2D([], [], color=COLOURS[k % len(COLOURS)], label=label)
               for k, (_, label) in enumerate(runs)]
    axes[0][0].legend(handles=handles, loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(out + ".partial.png", dpi=130)
    os.replace(out + ".partial.png", out)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
