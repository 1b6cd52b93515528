#pragma once
// `sweep view RESULTS_DIR`: one self-contained HTML file that plays a run back in a browser,
// offline, from the run's VTK snapshots (snapshots.pvd and the .vtp files it lists, as
// vtk_writer.hpp writes them): 2D disks, segments and polygons; 3D spheres, boxes, capsules,
// cylinders and meshes; coloured by speed or contact force; play, pause, scrub and a camera.
// three.js (Debian's libjs-three) and its OrbitControls are inlined, the frames are base64
// float32 arrays. Bad input (no snapshots, a file that is not a Sweep snapshot) is an
// InputError naming the file and the field.
#include <string>

namespace sweep {

struct ViewerOptions {
  std::string results_dir;
  std::string out_file;  // empty: RESULTS_DIR/view.html
  int every = 1;         // keep every N-th snapshot (and the last)
  // three.js's build and OrbitControls; empty: $SWEEP_THREE_DIR, else Debian's libjs-three
  std::string three_dir;
};

// Writes the page (atomically); returns its path.
std::string writeViewer(const ViewerOptions& options);

// One snapshot's text read and checked as writeViewer does (InputError naming `file` and the
// field), and the number of shapes it draws: the snapshot fuzzer's entry.
int readViewerSnapshot(const std::string& file, const std::string& text);

}  // namespace sweep
