#!/usr/bin/python3
"""The angle of repose of an adhesive powder by the lifted-cylinder test: grains settle in a tube
standing on a plate, the tube rises, the grains spread into a heap, and the heap's slope is
fitted. Run for several surface energies (ContactLaw's DMT pull-off force 4 pi gamma R*).

  /usr/bin/python3 bench/angle_of_repose.py OUT_DIR [--sweep ./build/sweep] \
      [--surface-energies 0,1e-4,5e-4,1e-3,3e-3] [--count 3000] [--figure FILE.png]

The scene (written to OUT_DIR/gamma_<value>/heap.yaml with the tube as tube.stl): Ti-6Al-4V-like
grains (density 4430 kg/m^3, radii uniform in [15, 25] um, friction 0.5, rolling resistance
0.1, restitution 0.5 as in examples/powder_bed) dropped at random into a smooth tube (no
friction, no adhesion) of inner radius 0.3 mm, settled for 30 ms, the tube lifted by 1.5 mm
over 0.1 s, 50 ms more of settling; Jean-Moreau, VEL, h = 2e-5, tolerance 1e-3. The angle: the heap's height profile
(the highest grain centre in rings 40 um wide about the heap's axis), fitted by a straight
line (least squares) over the rings outside the highest one whose height lies between 20 and
80 % of the heap's height; angle = atan(-slope) (fitted_angle: a cliff gets its chord). Both the fit window and the ring width are printed with it.
"""
import argparse
import csv
import json
import math
import os
import random
import subprocess
import sys

TUBE_RADIUS = 0.3e-3
TUBE_HEIGHT = 2.5e-3
RING = 40e-6


def write_tube(path, segments=96, rings=16):
    """An open cylindrical shell of triangles facing the axis (the grains are inside)."""
    def point(i, j):
        phi = 2 * math.pi * (j % segments) / segments
        return (TUBE_RADIUS * math.cos(phi), TUBE_RADIUS * math.sin(phi), TUBE_HEIGHT * i / rings)

    lines = ["solid tube"]
    for i in range(rings):
        for j in range(segments):
            a, b, c, d = point(i, j), point(i, j + 1), point(i + 1, j), point(i + 1, j + 1)
            for t in ((a, c, d), (a, d, b)):  # counter-clockwise seen from the axis
                lines += [" facet normal 0 0 0", "  outer loop"]
                lines += ["   vertex %.12e %.12e %.12e" % p for p in t]
                lines += ["  endloop", " endfacet"]
    lines.append("endsolid tube")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def write_scene(folder, surface_energy, count):
    os.makedirs(folder, exist_ok=True)
    write_tube(os.path.join(folder, "tube.stl"))
    # grains dropped at random (seeded) into the tube up to a fifth of the volume, none
    # overlapping: a lattice would stack them on vertical lines, which stand by symmetry
    rng = random.Random(1)
    inner = TUBE_RADIUS - 26e-6
    height = count * (4.0 / 3.0) * math.pi * (20e-6) ** 3 / (0.2 * math.pi * inner ** 2)
    cell = 50e-6
    grid, placed, grains = {}, [], []
    while len(placed) < count:
        radius = rng.uniform(15e-6, 25e-6)
        r, phi = inner * math.sqrt(rng.random()), 2 * math.pi * rng.random()
        p = (r * math.cos(phi), r * math.sin(phi), 26e-6 + height * rng.random())
        key = tuple(int(math.floor(c / cell)) for c in p)
        near = [placed[k] for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                for k in grid.get((key[0] + dx, key[1] + dy, key[2] + dz), [])]
        if any(math.dist(p, q[0]) < radius + q[1] + 1e-6 for q in near):
            continue
        grid.setdefault(key, []).append(len(placed))
        placed.append((p, radius))
        grains.append(f"  - {{name: g{len(grains)}, shape: sphere, radius: {radius:.4e}, "
                      f"material: powder, position: [{p[0]:.6e}, {p[1]:.6e}, {p[2]:.6e}]}}")
    grains = "\n".join(grains)
    scene = f"""# the lifted-cylinder test of bench/angle_of_repose.py
dimension: 3
gravity: [0, 0, -9.81]
materials:
  powder: {{density: 4430}}
  wall: {{}}
  tube: {{}}
contact:
  friction: 0.5
  restitution: 0.5
  rolling_resistance: 0.1
  surface_energy: {surface_energy!r}
  pairs:  # a smooth tube: with friction a column ten grains wide jams and rises with it
    - {{materials: [powder, tube], friction: 0, restitution: 0.5}}
bodies:
  - {{name: plate, shape: plane, position: [0, 0, 0], normal: [0, 0, 1], fixed: true,
     material: wall}}
  - name: tube
    shape: mesh
    file: tube.stl
    convex: false
    material: tube
    motion: {{type: keyframes, times: [0, 0.03, 0.13],
              positions: [[0, 0, 0], [0, 0, 0], [0, 0, 1.5e-3]], remove_at: 0.13}}
{grains}
scheme: {{coulomb: {{tolerance: 1.0e-3}}, normal_stage: {{tolerance: 1.0e-3}},
          friction_stage: {{tolerance: 1.0e-3}}, projection: {{max_rounds: 0}}}}
time: {{step: 2.0e-5, end: 0.18}}
"""
    path = os.path.join(folder, "heap.yaml")
    with open(path, "w") as f:
        f.write(scene)
    return path


def centres(final_state):
    q = [float(row[2]) for row in csv.reader(open(final_state)) if row[0] == "q"]
    return [(q[i], q[i + 1], q[i + 2]) for i in range(0, len(q), 7)]


def profile(points):
    """(ring centre radius, highest centre) about the heap's axis (its centroid in x, y)"""
    cx = sum(p[0] for p in points) / len(points)
    cy = sum(p[1] for p in points) / len(points)
    top = {}
    for x, y, z in points:
        ring = int(math.hypot(x - cx, y - cy) / RING)
        top[ring] = max(top.get(ring, -1.0), z)
    return [((ring + 0.5) * RING, top[ring]) for ring in sorted(top)]


def fitted_angle(rings, low=0.2, high=0.8):
    """The heap's flank: the rings outside the highest one whose height lies within [low, high]
    of the heap's height, fitted by least squares; with fewer than three such rings (a cliff),
    the chord from the last ring above `high` to the first one below `low`."""
    peak = max(h for _, h in rings)
    r_peak = max(r for r, h in rings if h == peak)
    outer = [(r, h) for r, h in rings if r > r_peak]
    window = [(r, h) for r, h in outer if low * peak <= h <= high * peak]
    if len(window) >= 3:
        n = len(window)
        mr = sum(r for r, _ in window) / n
        mh = sum(h for _, h in window) / n
        slope = sum((r - mr) * (h - mh) for r, h in window) / sum((r - mr) ** 2 for r, _ in window)
        return math.degrees(math.atan(-slope)), window
    top = [(r, h) for r, h in [(r_peak, peak)] + outer if h > high * peak][-1]
    foot = next(((r, h) for r, h in outer if r > top[0] and h < low * peak), None)
    if foot is None:
        return float("nan"), []
    return math.degrees(math.atan2(top[1] - foot[1], foot[0] - top[0])), [top, foot]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--sweep", default="./build/sweep")
    parser.add_argument("--surface-energies", default="0,1e-4,5e-4,1e-3,3e-3")
    parser.add_argument("--count", type=int, default=3000)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--figure", default="")
    args = parser.parse_args()
    rows, profiles = [], {}
    for value in args.surface_energies.split(","):
        gamma = float(value)
        folder = os.path.join(args.out, f"gamma_{value}")
        scene = write_scene(folder, gamma, args.count)
        run = subprocess.run([args.sweep, "run", scene, "--threads", str(args.threads), "--out",
                              os.path.join(folder, "run")],
                             capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"{scene}: sweep exited {run.returncode}:\n{run.stderr}")
        summary = json.load(open(os.path.join(folder, "run", "summary.json")))
        rings = profile(centres(os.path.join(folder, "run", "final_state.csv")))
        angle, window = fitted_angle(rings)
        profiles[value] = rings
        rows.append((value, angle, max(h for _, h in rings), window[0][0] if window else 0,
                     window[-1][0] if window else 0, summary["cpu_seconds"]))
    print("| surface energy (J/m^2) | angle (deg) | heap height (um) | fit window (um) | CPU (s) |")
    print("|---|---|---|---|---|")
    for value, angle, peak, r0, r1, cpu in rows:
        print(f"| {value} | {angle:.1f} | {peak * 1e6:.0f} | {r0 * 1e6:.0f}-{r1 * 1e6:.0f} | "
              f"{cpu:.1f} |")
    if args.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 3.5))
        for (value, angle, *_), rings in zip(rows, profiles.values()):
            ax.plot([r * 1e3 for r, _ in rings], [h * 1e3 for _, h in rings], marker=".",
                    label=f"gamma = {value} J/m^2: {angle:.1f} deg")
        ax.set_xlabel("distance from the heap's axis (mm)")
        ax.set_ylabel("highest grain centre (mm)")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(args.figure, dpi=120)


if __name__ == "__main__":
    main()
