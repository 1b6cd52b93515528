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
        # boxes as six quadrilaterals each
        self.assertGreater(data.GetNumberOfPolys(), 0)
        self.assertEqual(data.GetNumberOfPolys() % 6, 0)
        self.assertEqual(int((kind == 1).sum()), 800)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
