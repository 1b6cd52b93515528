#!/usr/bin/python3
"""The VTK snapshots as ParaView sees them: every file of snapshots.pvd read by VTK's own XML
reader (Debian's python3-vtk9), its arrays and cells checked, and the last snapshot's disks
against the run's final_state.csv. Usage: vtk_reader_test.py SWEEP SOURCE_DIR"""
import csv
import os
import subprocess
import sys
import unittest
import xml.etree.ElementTree as ET

import vtk
from vtk.util.numpy_support import vtk_to_numpy

from scratch import scratch_dir

SWEEP = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else "sweep"
SOURCE = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else "."


def read(path):
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    if reader.GetErrorCode() != 0:
        raise RuntimeError(f"{path}: VTK error {reader.GetErrorCode()}")
    return reader.GetOutput()


class Snapshots(unittest.TestCase):
    def run_scene(self, scene, *options):
        out = os.path.join(scratch_dir(self, "sweep_vtk_"), "out")
        result = subprocess.run([SWEEP, "run", os.path.join(SOURCE, scene), "--out", out,
                                 "--quiet", *options], capture_output=True, text=True, timeout=600)
        self.assertEqual(result.returncode, 0, result.stderr)
        datasets = ET.parse(os.path.join(out, "snapshots.pvd")).getroot().findall(
            "./Collection/DataSet")
        return out, [(float(d.get("timestep")), read(os.path.join(out, d.get("file"))))
                     for d in datasets]

    def test_funnel_disks_are_where_the_run_left_them(self):
        out, snapshots = self.run_scene("examples/funnel/funnel.yaml", "--t-end", "0.02", "--set",
                                        "output.vtk_interval=0.005")
        self.assertEqual([round(t, 9) for t, _ in snapshots], [0.0, 0.005, 0.01, 0.015, 0.02])
        for _, data in snapshots:
            point_data = data.GetPointData()
            for name in ("body_id", "kind", "shape", "radius", "velocity", "contact_force"):
                self.assertIsNotNone(point_data.GetArray(name), name)
            self.assertEqual(point_data.GetArray("velocity").GetNumberOfComponents(), 3)
            dimension = data.GetFieldData().GetArray("dimension")
            self.assertEqual(dimension.GetValue(0), 2)
            self.assertEqual(data.GetNumberOfVerts(), 50)  # the disks
            self.assertEqual(data.GetNumberOfLines(), 3)  # the walls and the shutter below
        # the last snapshot is the final state: the disks' centres are q's (x, y) per disk
        _, last = snapshots[-1]
        with open(os.path.join(out, "final_state.csv")) as f:
            q = [float(r["value"]) for r in csv.DictReader(f) if r["vector"] == "q"]
        points = vtk_to_numpy(last.GetPoints().GetData())
        body = vtk_to_numpy(last.GetPointData().GetArray("body_id"))
        kind = vtk_to_numpy(last.GetPointData().GetArray("kind"))
        radius = vtk_to_numpy(last.GetPointData().GetArray("radius"))
        disks = [k for k in range(len(points)) if kind[k] == 1]
        self.assertEqual(len(disks), 50)
        for k in disks:
            i = int(body[k])
            self.assertAlmostEqual(points[k][0], q[3 * i], delta=1e-8)
            self.assertAlmostEqual(points[k][1], q[3 * i + 1], delta=1e-8)
            self.assertEqual(points[k][2], 0.0)
            self.assertGreater(radius[k], 0.0)

    def test_powder_bed_spheres_and_boxes(self):
        _, snapshots = self.run_scene("examples/powder_bed/powder_bed_reduced.yaml", "--t-end",
                                      "0.002", "--set", "output.vtk_interval=1e-3")
        _, data = snapshots[-1]
        self.assertEqual(data.GetFieldData().GetArray("dimension").GetValue(0), 3)
        gravity = data.GetFieldData().GetArray("gravity")
        self.assertEqual([gravity.GetComponent(0, k) for k in range(3)], [0.0, -9.81, 0.0])
        kind = vtk_to_numpy(data.GetPointData().GetArray("kind"))
        verts = data.GetVerts()
        self.assertEqual(verts.GetNumberOfCells(), 800)  # the spheres
        # boxes as six quadrilaterals each, and a square of each of the three planes (the plate
        # and the two end walls) under the other shapes, as wide as them
        polys = data.GetNumberOfPolys()
        self.assertGreater(polys, 3)
        self.assertEqual((polys - 3) % 6, 0)
        shape = vtk_to_numpy(data.GetPointData().GetArray("shape"))
        points = vtk_to_numpy(data.GetPoints().GetData())
        plane_points = points[shape == 6]
        self.assertEqual(len(plane_points), 3 * 4)
        self.assertTrue((kind[shape == 6] == 0).all())
        # the plate y = 0: a square in it, as wide along x as the bed and the walls
        plate = [p for p in plane_points if abs(p[1]) < 1e-12]
        self.assertEqual(len(plate), 4)
        bodies = points[shape != 6]
        self.assertGreater(max(p[0] for p in plate) - min(p[0] for p in plate),
                           bodies[:, 0].max() - bodies[:, 0].min())
        self.assertEqual(int((kind == 1).sum()), 800)

    def contacts(self, out):
        datasets = ET.parse(os.path.join(out, "contacts.pvd")).getroot().findall(
            "./Collection/DataSet")
        return [(float(d.get("timestep")), read(os.path.join(out, d.get("file"))))
                for d in datasets]

    def test_contact_network_of_a_resting_box_carries_its_weight(self):
        # a 2 kg box resting flat on a plane: its four corners' forces sum to m g
        scene = os.path.join(scratch_dir(self, "sweep_vtk_box_"), "box.yaml")
        with open(scene, "w") as f:
            f.write("dimension: 3\ngravity: [0, 0, -9.81]\ncontact: {friction: 0.5, restitution: 0}\n"
                    "bodies:\n"
                    "  - {name: floor, shape: plane, position: [0, 0, 0], normal: [0, 0, 1], fixed: true}\n"
                    "  - {name: box, shape: box, size: [0.2, 0.1, 0.05], position: [0, 0, 0.025], mass: 2}\n"
                    "time: {step: 1.0e-3, end: 0.05}\noutput: {vtk_interval: 0.025}\n")
        out, snapshots = self.run_scene(scene)
        network = self.contacts(out)
        self.assertEqual([t for t, _ in network], [t for t, _ in snapshots])
        self.assertEqual(network[0][1].GetNumberOfPoints(), 0)  # no step taken yet
        _, last = network[-1]
        self.assertEqual(last.GetNumberOfVerts(), 4)
        self.assertEqual(last.GetNumberOfLines(), 4)
        data = last.GetPointData()
        for name in ("normal_impulse", "tangential_impulse", "normal", "force", "gap", "body_a",
                     "body_b"):
            self.assertIsNotNone(data.GetArray(name), name)
        force = vtk_to_numpy(data.GetArray("force"))
        points = vtk_to_numpy(last.GetPoints().GetData())
        bodies = {int(b) for b in vtk_to_numpy(data.GetArray("body_b"))}
        self.assertEqual(bodies, {0})
        # each contact is three points (its point, then the two sides' centres): one force each
        self.assertAlmostEqual(sum(force[3 * c][2] for c in range(4)), 2 * 9.81, delta=1e-6)
        for c in range(4):
            self.assertAlmostEqual(points[3 * c][2], 0.0, delta=1e-6)  # the corners, on the floor
            self.assertAlmostEqual(points[3 * c + 2][2], 0.025, delta=1e-6)  # the box's centre

    def test_a_robot_is_drawn_by_its_visual_meshes(self):
        # the UR10 of tests/data/packages: its links' visuals (COLLADA, Z up) are the same boxes
        # as their collision meshes (STL), so role 1 (visual) and role 2 (the collision shapes
        # the visuals draw) hold the same points; the ee_link box and the floor have no visual
        out, snapshots = self.run_scene("tests/data/packages/scenes/ur10_on_floor.yaml",
                                        "--t-end", "0.01", "--set", "output.vtk_interval=0.005")
        _, last = snapshots[-1]
        role = vtk_to_numpy(last.GetPointData().GetArray("role"))
        points = vtk_to_numpy(last.GetPoints().GetData())
        visual = sorted(tuple(round(x, 9) for x in p) for p, r in zip(points, role) if r == 1)
        hidden = sorted(tuple(round(x, 9) for x in p) for p, r in zip(points, role) if r == 2)
        self.assertEqual(len(visual), 7 * 8)  # seven links, a box's eight corners each
        self.assertEqual(visual, hidden)
        self.assertEqual(int((role == 0).sum()), 8 + 4)  # the ee_link box, the floor's square
        self.assertEqual(last.GetNumberOfPolys(), 2 * 7 * 12 + 6 + 1)

    def test_contact_network_of_a_periodic_powder_bed_stays_local(self):
        # contacts across the periodic bound are drawn to the image they meet, not across the bed
        out, _ = self.run_scene("examples/powder_bed/powder_bed_reduced.yaml", "--t-end", "0.01",
                                "--set", "output.vtk_interval=0.005")
        _, last = self.contacts(out)[-1]
        lines = last.GetNumberOfLines()
        self.assertGreater(lines, 100)
        points = vtk_to_numpy(last.GetPoints().GetData())
        body_b = vtk_to_numpy(last.GetPointData().GetArray("body_b"))
        impulse = vtk_to_numpy(last.GetPointData().GetArray("normal_impulse"))
        self.assertTrue((impulse >= 0.0).all())
        self.assertTrue((body_b >= 0).all())  # b is a grain in every grain contact
        # the bed is periodic along z on [0, 0.4 mm): some contacts meet a grain's image, and
        # their segment ends at that image's centre, outside the period
        period = 4e-4
        across = [c for c in range(lines)
                  if not all(0.0 <= points[3 * c + k][2] < period for k in (1, 2))]
        self.assertGreater(len(across), 0)
        longest = max(sum((points[3 * c + 1] - points[3 * c + 2]) ** 2) ** 0.5
                      for c in range(lines))
        self.assertLess(longest, 1e-4)  # grains of at most 25 um radius

if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
