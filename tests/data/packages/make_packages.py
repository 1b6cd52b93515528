#!/usr/bin/python3
"""Writes the meshes of the three robot description packages under src/ (tests of real URDFs).

The URDFs (src/*/urdf/) carry the robots' published kinematics, inertias, limits and mesh
paths; the vendors' meshes are not redistributed here, so each link gets a stand-in of the
same layout: a box along the segment from the link's frame to its child joint, written where
the URDF looks for it and in the formats the packages use (binary STL for collision, COLLADA
for visuals, Z up, in millimetres for the KR5 as its files are). Rerun after editing LINKS:
  /usr/bin/python3 tests/data/packages/make_packages.py
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

# package, mesh folder, unit scale of the files (the URDF's <mesh scale> undoes it), and per
# link: its mesh's base name, the far end of its segment in the link frame (m), the box's width
# and whether the box rests on z = 0 (a base standing on the floor)
LINKS = {
    ("ur_description", "meshes/ur10", 1.0): [
        ("base", (0, 0, 0.038), 0.15, True),
        ("shoulder", (0, 0.22, 0), 0.15, False),
        ("upperarm", (0, -0.17, 0.612), 0.13, False),
        ("forearm", (0, 0, 0.5723), 0.10, False),
        ("wrist1", (0, 0.1157, 0), 0.09, False),
        ("wrist2", (0, 0, 0.0922), 0.09, False),
        ("wrist3", (0, 0.06, 0), 0.08, False),
    ],
    ("kuka_kr5_support", "meshes/kr5_arc", 1000.0): [
        ("base_link", (0, 0, 0.30), 0.30, True),
        ("link_1", (0.18, 0, 0), 0.20, False),
        ("link_2", (0.6, 0, 0), 0.14, False),
        ("link_3", (0.62, -0.12, 0), 0.10, False),
        ("link_4", (0, 0, 0.05), 0.09, False),
        ("link_5", (0, 0, 0.05), 0.08, False),
        ("link_6", (0, 0, -0.08), 0.06, False),
    ],
    ("herb_description", "meshes/wam", 1.0): [
        ("wam_base", (0.22, 0.14, 0.30), 0.20, True),
        ("wam1", (0, 0, -0.10), 0.16, False),
        ("wam2", (0, 0, 0.10), 0.12, False),
        ("wam3", (0.045, 0, 0.55), 0.09, False),
        ("wam4", (-0.045, -0.30, 0), 0.08, False),
        ("wam5", (0, 0, 0.05), 0.07, False),
        ("wam6", (0, 0, 0.05), 0.07, False),
        ("wam7", (0, 0, 0.06), 0.06, False),
    ],
}


def box_around(end, width, on_floor):
    """The 8 corners of a box from the origin (or the floor) to `end`, `width` across."""
    ex, ey, ez = end
    if on_floor:  # an axis-aligned block from z = 0 up to the end's height
        lo = (min(0, ex) - width / 2, min(0, ey) - width / 2, 0.0)
        hi = (max(0, ex) + width / 2, max(0, ey) + width / 2, max(ez, width / 2))
        return [(hi[0] if k & 1 else lo[0], hi[1] if k & 2 else lo[1], hi[2] if k & 4 else lo[2])
                for k in range(8)]
    length = math.sqrt(ex * ex + ey * ey + ez * ez)
    axis = (ex / length, ey / length, ez / length) if length > 0 else (0.0, 0.0, 1.0)
    helper = (1.0, 0.0, 0.0) if abs(axis[0]) < 0.9 else (0.0, 1.0, 0.0)
    u = cross(axis, helper)
    u = scale(u, 1 / math.sqrt(dot(u, u)))
    w = cross(axis, u)
    corners = []
    for k in range(8):
        along = (length + width / 2) if k & 4 else -width / 2
        a = width / 2 if k & 1 else -width / 2
        b = width / 2 if k & 2 else -width / 2
        corners.append(tuple(along * axis[i] + a * u[i] + b * w[i] for i in range(3)))
    return corners


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def scale(a, s):
    return tuple(s * x for x in a)


# the box's 12 triangles, outward (corner k: bit 0 x, bit 1 y, bit 2 z in the box's frame)
FACES = [(0, 2, 3), (0, 3, 1), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4),
         (2, 6, 7), (2, 7, 3), (0, 4, 6), (0, 6, 2), (1, 3, 7), (1, 7, 5)]


def outward_triangles(corners):
    centre = scale(tuple(map(sum, zip(*corners))), 1 / 8)
    triangles = []
    for f in FACES:
        a, b, c = (corners[i] for i in f)
        n = cross(tuple(b[i] - a[i] for i in range(3)), tuple(c[i] - a[i] for i in range(3)))
        out = dot(n, tuple(a[i] - centre[i] for i in range(3))) > 0
        triangles.append(f if out else (f[0], f[2], f[1]))
    return triangles


def write_stl(path, corners, triangles):
    with open(path, "wb") as f:
        f.write(b"Sweep stand-in link mesh".ljust(80, b" "))
        f.write(struct.pack("<I", len(triangles)))
        for t in triangles:
            f.write(struct.pack("<3f", 0, 0, 0))
            for i in t:
                f.write(struct.pack("<3f", *corners[i]))
            f.write(struct.pack("<H", 0))


def write_dae(path, corners, triangles, unit):
    positions = " ".join("%.9g" % x for c in corners for x in c)
    indices = " ".join(str(i) for t in triangles for i in t)
    meter = 1.0 / unit
    unit_name = "millimeter" if unit == 1000.0 else "meter"
    with open(path, "w") as f:
        f.write(f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="{unit_name}" meter="{meter:g}"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries>
    <geometry id="link" name="link"><mesh>
      <source id="link-pos"><float_array id="link-pos-array" count="24">{positions}</float_array>
        <technique_common><accessor source="#link-pos-array" count="8" stride="3">
          <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
        </accessor></technique_common></source>
      <vertices id="link-vtx"><input semantic="POSITION" source="#link-pos"/></vertices>
      <triangles count="12"><input semantic="VERTEX" source="#link-vtx" offset="0"/><p>{indices}</p></triangles>
    </mesh></geometry>
  </library_geometries>
  <library_visual_scenes><visual_scene id="scene"><node id="link-node" name="link">
    <instance_geometry url="#link"/></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
""")


def main():
    for (package, folder, unit), links in LINKS.items():
        root = os.path.join(HERE, "src", package, folder)
        for sub in ("collision", "visual") if package != "herb_description" else ("",):
            os.makedirs(os.path.join(root, sub), exist_ok=True)
        for name, end, width, on_floor in links:
            corners = box_around(end, width, on_floor)
            triangles = outward_triangles(corners)
            in_unit = [scale(c, unit) for c in corners]
            if package == "herb_description":  # DART's layout: both side by side
                write_stl(os.path.join(root, name + "_collision.STL"), in_unit, triangles)
                write_dae(os.path.join(root, name + ".dae"), in_unit, triangles, unit)
            else:
                write_stl(os.path.join(root, "collision", name + ".stl"), in_unit, triangles)
                write_dae(os.path.join(root, "visual", name + ".dae"), in_unit, triangles, unit)


if __name__ == "__main__":
    main()
