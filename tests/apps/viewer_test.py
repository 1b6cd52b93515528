#!/usr/bin/python3
"""`sweep view`: the page it writes for the funnel and a powder bed, rendered by headless
Chromium (Debian's chromium, WebGL on SwiftShader) and checked for drawn content; and its
errors on bad results folders. Usage: viewer_test.py SWEEP SOURCE_DIR"""
import os
import re
import shutil
import subprocess
import sys
import unittest

import matplotlib.image

from scratch import scratch_dir

SWEEP = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else "sweep"
SOURCE = os.path.abspath(sys.argv[2]) if len(sys.argv) > 2 else "."
CHROMIUM = shutil.which("chromium")
WIDTH, HEIGHT, BAR = 900, 700, 44  # window, and the control bar under the canvas


def sweep(*args):
    return subprocess.run([SWEEP, *args], capture_output=True, text=True, timeout=600)


def screenshot(page, png, fragment):
    # a fresh profile per shot: Chromium's default one is shared and locked between processes
    profile = os.path.join(os.path.dirname(png), "chromium-profile")
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--use-angle=swiftshader",
                    "--enable-unsafe-swiftshader", "--disable-dev-shm-usage", "--virtual-time-budget=5000",
                    f"--user-data-dir={profile}", f"--window-size={WIDTH},{HEIGHT}",
                    f"--screenshot={png}", f"file://{page}#{fragment}"],
                   capture_output=True, timeout=120, check=True)
    image = matplotlib.image.imread(png)[:, :, :3]
    return image[:HEIGHT - BAR - 2]  # the canvas only


def drawn(canvas):
    """Fraction of the canvas not white, and the set of its colours (to 1/16)."""
    background = (canvas > 0.97).all(axis=2)
    colours = {tuple(c) for c in (canvas[~background] * 16).astype(int).reshape(-1, 3)}
    return 1.0 - background.mean(), colours


def near(canvas, rgb, tolerance=0.12):
    return int((abs(canvas - rgb) < tolerance).all(axis=2).sum())


VIRIDIS_LOW, VIRIDIS_HIGH = (0.267, 0.005, 0.329), (0.993, 0.906, 0.144)
PLAIN, PALE = (0.80, 0.62, 0.38), (0.88, 0.88, 0.88)  # bodies uncoloured; behind force chains


class Page(unittest.TestCase):
    """The page of a run: self-contained, and drawn by a browser."""

    @classmethod
    def setUpClass(cls):
        if CHROMIUM is None:
            raise RuntimeError("chromium not found: scripts/install-deps.sh --tests installs it")

    def run_scene(self, scene, *options):
        out = os.path.join(scratch_dir(self, "sweep_view_"), "out")
        result = sweep("run", os.path.join(SOURCE, scene), "--out", out, "--quiet", *options)
        self.assertEqual(result.returncode, 0, result.stderr)
        result = sweep("view", out)
        self.assertEqual(result.returncode, 0, result.stderr)
        page = os.path.join(out, "view.html")
        self.assertIn(page, result.stdout)
        with open(page) as f:
            text = f.read()
        # offline: nothing is fetched (three.js is inlined)
        self.assertNotRegex(text, r"<script[^>]*\ssrc=")
        self.assertNotRegex(text, r"<link[^>]*\shref=")
        self.assertIn("OrbitControls", text)
        return out, page

    def assert_coloured_by_speed(self, canvas, minimum_area):
        area, colours = drawn(canvas)
        self.assertGreater(area, minimum_area)
        self.assertLess(area, 0.9)
        self.assertGreater(len(colours), 20)
        # both ends of the colour scale are drawn: bodies at rest and bodies moving fast
        self.assertGreater(near(canvas, VIRIDIS_HIGH), 50)
        self.assertGreater(near(canvas, VIRIDIS_LOW, 0.2), 50)

    def test_funnel(self):
        out, page = self.run_scene("examples/funnel/funnel.yaml", "--t-end", "0.05", "--set",
                                   "output.vtk_interval=0.005")
        canvas = screenshot(page, os.path.join(out, "last.png"), "frame=last")
        self.assert_coloured_by_speed(canvas, 0.05)
        # the first frame holds the disks where the generator put them: another picture
        first = screenshot(page, os.path.join(out, "first.png"), "frame=0")
        self.assertGreater(abs(first - canvas).max(axis=2).mean(), 0.01)
        # without colour the disks take one colour and the scale's ends are gone
        plain = screenshot(page, os.path.join(out, "plain.png"), "frame=last&colour=none")
        self.assertGreater(drawn(plain)[0], 0.05)
        self.assertEqual(near(plain, VIRIDIS_HIGH), 0)
        # force chains: the disks pale, each contact a band between two centres in the scale's
        # colours (the last frame's pile at the low end) drawn over them
        chains = screenshot(page, os.path.join(out, "chains.png"), "frame=last&colour=chains")
        self.assertEqual(near(chains, PLAIN, 0.05), 0)
        self.assertGreater(near(chains, PALE, 0.03), 0.02 * chains.shape[0] * chains.shape[1])
        self.assertGreater(near(chains, VIRIDIS_LOW, 0.2), 200)
        self.assertGreater(near(chains, VIRIDIS_LOW, 0.2), 10 * near(plain, VIRIDIS_LOW, 0.2))
        # results without contact networks (written before them) give a page without the option
        os.remove(os.path.join(out, "contacts.pvd"))
        result = sweep("view", out)
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(page) as f:
            self.assertIn('"chains":false', f.read())

    def test_powder_bed(self):
        out, page = self.run_scene("examples/powder_bed/powder_bed_reduced.yaml", "--t-end",
                                   "0.004", "--set", "output.vtk_interval=1e-3")
        canvas = screenshot(page, os.path.join(out, "last.png"), "frame=last")
        self.assert_coloured_by_speed(canvas, 0.1)
        # without colour the spheres are tan (red over blue), the walls of the heap's box, drawn
        # as boxes, blue-grey: both cover a part of the picture
        plain = screenshot(page, os.path.join(out, "plain.png"), "frame=last&colour=none")
        background = (plain > 0.97).all(axis=2)
        bluish = (plain[:, :, 2] > plain[:, :, 0] + 0.05) & ~background
        reddish = (plain[:, :, 0] > plain[:, :, 2] + 0.05) & ~background
        self.assertGreater(bluish.mean(), 0.05)
        self.assertGreater(reddish.mean(), 0.02)

    def test_a_plane_is_drawn_under_the_bodies(self):
        # a box on a plane: the plane as a see-through grey square under it, wider than the box
        folder = scratch_dir(self, "sweep_view_plane_")
        scene = os.path.join(folder, "box.yaml")
        with open(scene, "w") as f:
            f.write("dimension: 3\ngravity: [0, 0, -9.81]\ncontact: {friction: 0.5}\nbodies:\n"
                    "  - {name: floor, shape: plane, position: [0, 0, 0], normal: [0, 0, 1], fixed: true}\n"
                    "  - {name: box, shape: box, size: [0.2, 0.1, 0.05], position: [0, 0, 0.025], mass: 1}\n"
                    "time: {step: 1.0e-3, end: 0.01}\noutput: {vtk_interval: 0.005}\n")
        out, page = self.run_scene(scene)
        canvas = screenshot(page, os.path.join(out, "plane.png"), "frame=last&colour=none")
        see_through = 1 - 0.3 * (1 - 0.62)  # the wall grey at opacity 0.3 over white
        floor = near(canvas, (see_through,) * 3, 0.02)
        box = int(((canvas[:, :, 0] > canvas[:, :, 2] + 0.05)).sum())  # tan, shaded
        self.assertGreater(box, 1000)
        self.assertGreater(floor, 0.05 * canvas.shape[0] * canvas.shape[1])


class BadInput(unittest.TestCase):
    """Exit code 2 and a message naming the file and the field."""

    def setUp(self):
        self.out = os.path.join(scratch_dir(self, "sweep_view_bad_"), "out")
        result = sweep("run", os.path.join(SOURCE, "examples/tutorial/hopper.yaml"), "--out",
                       self.out, "--quiet", "--t-end", "0.01", "--set", "output.vtk_interval=0.005")
        self.assertEqual(result.returncode, 0, result.stderr)
        self.snapshot = os.path.join(self.out, "vtk", "snapshot_000001.vtp")

    def assert_refused(self, *message, args=()):
        result = sweep("view", self.out, *args)
        self.assertEqual(result.returncode, 2, result.stdout + result.stderr)
        for m in message:
            self.assertIn(m, result.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.out, "view.html")))

    def test_a_folder_without_snapshots(self):
        os.remove(os.path.join(self.out, "snapshots.pvd"))
        self.assert_refused("snapshots.pvd: not found", "output.vtk_interval")

    def test_a_missing_folder(self):
        result = sweep("view", os.path.join(self.out, "nothing"))
        self.assertEqual(result.returncode, 2)
        self.assertIn("nothing: not a results folder", result.stderr)

    def test_a_truncated_array(self):
        with open(self.snapshot) as f:
            text = f.read()
        # drop the last radius
        text = re.sub(r'(Name="radius" format="ascii">\n(?:\S+ )*)\S+ \n', r"\1\n", text)
        with open(self.snapshot, "w") as f:
            f.write(text)
        self.assert_refused("snapshot_000001.vtp: radius: holds", "values, expected")

    def test_a_value_that_is_not_a_number(self):
        with open(self.snapshot) as f:
            text = f.read()
        text = text.replace('Name="points" NumberOfComponents="3" format="ascii">\n',
                            'Name="points" NumberOfComponents="3" format="ascii">\nx ', 1)
        with open(self.snapshot, "w") as f:
            f.write(text)
        self.assert_refused("snapshot_000001.vtp: points: holds a value that is not a number")

    def test_a_connectivity_out_of_range(self):
        with open(self.snapshot) as f:
            text = f.read()
        text = re.sub(r'(<Verts>\n<DataArray type="Int32" Name="connectivity" format="ascii">\n)\d+',
                      r"\g<1>99999999", text)
        with open(self.snapshot, "w") as f:
            f.write(text)
        self.assert_refused("Verts connectivity: names a point that does not exist")

    def test_a_collection_naming_a_file_outside(self):
        pvd = os.path.join(self.out, "snapshots.pvd")
        with open(pvd) as f:
            text = f.read()
        with open(pvd, "w") as f:
            f.write(text.replace('file="vtk/', 'file="../../etc/', 1))
        self.assert_refused("snapshots.pvd: DataSet file: must be a path inside")

    def test_an_out_path_that_cannot_be_a_page(self):
        folder = os.path.join(self.out, "vtk")
        self.assert_refused("--out: " + folder + " is a folder", args=("--out", folder))
        missing = os.path.join(self.out, "no", "page.html")
        self.assert_refused("the folder " + os.path.dirname(missing) + " does not exist",
                            args=("--out", missing))
        self.assertEqual([f for f in os.listdir(self.out) if f.endswith(".partial")], [])

    def test_every_below_one(self):
        self.assert_refused("--every: must be >= 1, got 0", args=("--every", "0"))


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
