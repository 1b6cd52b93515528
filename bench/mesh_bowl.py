#!/usr/bin/python3
"""A spherical bowl as a triangle mesh (an ASCII STL: `rings` x `segments` quads, each split in
two, facing the sphere's centre, open at 70 degrees; radius 0.25 m, bottom at the origin) and
a scene pouring 196 spheres of radius 1 cm into it (a 7 x 7 x 4 lattice, 0.3 s at h = 1e-3):
the closed forms against a large mesh (bench/compare_builds.py, case "mesh bowl pour").

  /usr/bin/python3 bench/mesh_bowl.py OUT_DIR [--rings 64] [--segments 128]
"""
import argparse
import math
import os


def write_bowl(path, rings, segments, radius=0.25, opening=math.radians(70)):
    centre = (0.0, 0.0, radius)

    def point(i, j):
        theta, phi = opening * i / rings, 2 * math.pi * (j % segments) / segments
        return (radius * math.sin(theta) * math.cos(phi) + 0.0,
                radius * math.sin(theta) * math.sin(phi) + 0.0,
                radius - radius * math.cos(theta) + 0.0)

    def facing_centre(t):
        u = [t[1][k] - t[0][k] for k in range(3)]
        v = [t[2][k] - t[0][k] for k in range(3)]
        n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        to_centre = [centre[k] - sum(p[k] for p in t) / 3 for k in range(3)]
        return t if sum(a * b for a, b in zip(n, to_centre)) > 0 else (t[0], t[2], t[1])

    lines = ["solid bowl"]
    for i in range(rings):
        for j in range(segments):
            a, b, c, d = point(i, j), point(i, j + 1), point(i + 1, j), point(i + 1, j + 1)
            for t in ([(a, d, c)] if i == 0 else [(a, d, c), (a, b, d)]):
                lines += [" facet normal 0 0 0", "  outer loop"]
                lines += ["   vertex %.12e %.12e %.12e" % p for p in facing_centre(t)]
                lines += ["  endloop", " endfacet"]
    lines.append("endsolid bowl")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def write_scene(folder, rings=64, segments=128):
    os.makedirs(folder, exist_ok=True)
    write_bowl(os.path.join(folder, "bowl.stl"), rings, segments)
    lines = ["dimension: 3", "bodies:",
             "  - {name: bowl, shape: mesh, file: bowl.stl, convex: false, fixed: true}"]
    k = 0
    for ix in range(-3, 4):
        for iy in range(-3, 4):
            for iz in range(4):
                x = ix * 0.025 + 1e-3 * math.sin(7.0 * k)  # off the lattice, reproducibly
                lines.append(f"  - {{name: s{k}, shape: sphere, radius: 0.01, mass: 0.01, "
                             f"position: [{x:.6g}, {iy * 0.025:.6g}, {0.08 + iz * 0.025:.6g}]}}")
                k += 1
    lines.append("time: {step: 1.0e-3, end: 0.3}")
    path = os.path.join(folder, "pour.yaml")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("out")
    parser.add_argument("--rings", type=int, default=64)
    parser.add_argument("--segments", type=int, default=128)
    args = parser.parse_args()
    print(write_scene(args.out, args.rings, args.segments))
