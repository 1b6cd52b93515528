#pragma once
// `sweep view RESULTS_DIR`: one self-contained HTML file that plays a run back in a browser,
// offline, from the run's VTK snapshots (snapshots.pvd and the .vtp files it lists, as
// vtk_writer.hpp writes them): 2D disks, segments and polygons; 3D spheres, boxes, capsules,
// cylinders and meshes; coloured by speed or contact force; play, pause, scrub and a camera.
// three.js (Debian's libjs-three) and its OrbitControls are inlined, the frames are base64
// float32 arrays. Bad input (no snapshots, a file that is not a Sweep snapshot) is an
// InputError naming the file and the field.
#include <cstddef>
#include <ostream>
#include <string>

namespace sweep {

struct ViewerOptions {
  std::string results_dir;
  std::string out_file;  // empty: RESULTS_DIR/view.html
  // keep every N-th snapshot (and the last); 0: every one, thinned when the page would pass
  // kMaxViewerPageBytes, with a note on `log`
  int every = 0;
  std::ostream* log = nullptr;
  // three.js's build and OrbitControls; empty: $SWEEP_THREE_DIR, else Debian's libjs-three
  std::string three_dir;
};

// V8, the engine of most browsers, holds no string longer than about 2^29 characters: a page
// past that does not open.
inline constexpr double kMaxViewerPageBytes = 5e8;

// Snapshots kept out of `count` when every `every`-th one and the last are.
std::size_t keptSnapshots(std::size_t count, std::size_t every);

// What a page of `snapshots` frames takes per kept snapshot, in the file and in memory while
// it is assembled, against the memory this process may use.
struct ViewerPage {
  std::size_t snapshots = 0;
  double bytes_per_snapshot = 0.0, memory_per_snapshot = 0.0, memory_limit = 0.0;
};

// The smallest --every from every_given (0: 1) whose page fits kMaxViewerPageBytes and the
// memory limit. InputError when every_given was set and does not fit (naming the one that
// does) or when no thinning fits; a note on `log` when it thins.
int fittingEvery(const ViewerPage& page, int every_given, std::ostream* log);

// Writes the page (atomically); returns its path. The page's size is measured on the first
// snapshot before the others are read: past kMaxViewerPageBytes, or past the memory this
// process may use to assemble it, an --every that was given is refused, naming the smallest
// that fits, and otherwise the frames are thinned to fit.
std::string writeViewer(const ViewerOptions& options);

// One snapshot's text read and checked as writeViewer does (InputError naming `file` and the
// field), and the number of shapes it draws: the snapshot fuzzer's entry.
int readViewerSnapshot(const std::string& file, const std::string& text);

}  // namespace sweep
