#include "apps/sweep/viewer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "apps/sweep/run.hpp"
#include "apps/sweep/vtk_writer.hpp"
#include "contact/shape.hpp"
#include "framework/error.hpp"
#include "framework/memory.hpp"

namespace sweep {

extern const char* const kViewerPage;  // viewer_page.html, embedded by the build

namespace {

// Snapshots larger than this are not a Sweep run's: refuse them before reading them whole.
constexpr std::uintmax_t kMaxSnapshotBytes = std::uintmax_t{1} << 30;
constexpr std::uintmax_t kMaxCollectionBytes = std::uintmax_t{64} << 20;

std::string readWhole(const std::filesystem::path& path, std::uintmax_t limit,
                      const std::string& what) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw InputError(path.string() + ": " + what + " not found");
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error || size > limit)
    throw InputError(path.string() + ": " + what + " of " + std::to_string(size) +
                     " bytes, more than a Sweep run writes");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) throw InputError(path.string() + ": cannot be read");
  return text.str();
}

// The value of attribute `name` in the tag text (empty when absent).
std::string attribute(const std::string& tag, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const std::size_t at = tag.find(key);
  if (at == std::string::npos) return {};
  const std::size_t begin = at + key.size();
  const std::size_t end = tag.find('"', begin);
  return end == std::string::npos ? std::string() : tag.substr(begin, end - begin);
}

double norm3(const std::vector<double>& x, int k) {
  return std::sqrt(x[3 * k] * x[3 * k] + x[3 * k + 1] * x[3 * k + 1] + x[3 * k + 2] * x[3 * k + 2]);
}

struct Snapshot {
  double time = 0.0;
  int dimension = 0;            // 0: not stated
  std::vector<double> gravity;  // empty: not stated
  std::vector<double> points, radius, velocity, force;
  std::vector<int> kind, shape, role;  // role: kRoleCollision when the snapshot has none
  std::vector<int> verts, verts_offsets, lines, lines_offsets, polys, polys_offsets;
};

class SnapshotReader {
 public:
  SnapshotReader(std::string file, std::string text)
      : file_(std::move(file)), text_(std::move(text)) {}

  Snapshot read(double time) {
    Snapshot s;
    s.time = time;
    const std::size_t piece = pieceAt();
    const std::string piece_tag = text_.substr(piece, text_.find('>', piece) - piece);
    const long n = count(piece_tag, "NumberOfPoints");
    const std::size_t field = text_.find("Name=\"dimension\"");
    if (field != std::string::npos && field < piece) {
      std::vector<int> d;
      readArray(field, "dimension", d);
      if (d.size() != 1 || (d[0] != 2 && d[0] != 3)) fail("dimension", "must be 2 or 3");
      s.dimension = d[0];
    }
    const std::size_t g = text_.find("Name=\"gravity\"");
    if (g != std::string::npos && g < piece) {
      readArray(g, "gravity", s.gravity);
      if (s.gravity.size() != 3) fail("gravity", "must hold three values");
      for (double x : s.gravity)
        if (!std::isfinite(x)) fail("gravity", "holds a value that is not finite");
    }
    array("points", s.points, 3 * n, piece);
    array("radius", s.radius, n, piece);
    array("velocity", s.velocity, 3 * n, piece);
    array("contact_force", s.force, 3 * n, piece);
    array("kind", s.kind, n, piece);
    if (text_.find("Name=\"shape\"", piece) != std::string::npos)
      array("shape", s.shape, n, piece);
    else
      s.shape.assign(n, -1);
    if (text_.find("Name=\"role\"", piece) != std::string::npos) {
      array("role", s.role, n, piece);
      for (int r : s.role)
        if (r < kRoleCollision || r > kRoleHidden) fail("role", "must be 0, 1 or 2");
    } else {
      s.role.assign(n, kRoleCollision);
    }
    cells("Verts", s.verts, s.verts_offsets, n, count(piece_tag, "NumberOfVerts"));
    cells("Lines", s.lines, s.lines_offsets, n, count(piece_tag, "NumberOfLines"));
    cells("Polys", s.polys, s.polys_offsets, n, count(piece_tag, "NumberOfPolys"));
    for (int k = 0; k < static_cast<int>(s.verts_offsets.size()); ++k)
      if (s.verts_offsets[k] != k + 1) fail("Verts", "must hold one point per vertex cell");
    for (int k = 0; k < static_cast<int>(s.lines_offsets.size()); ++k)
      if (s.lines_offsets[k] != 2 * (k + 1)) fail("Lines", "must hold two points per line");
    for (double x : s.points)
      if (!std::isfinite(x)) fail("points", "holds a value that is not finite");
    for (double r : s.radius)
      if (!(r >= 0.0 && std::isfinite(r))) fail("radius", "holds a negative or non-finite value");
    return s;
  }

  // A contact network (vtk_writer.hpp): per line (the segment between the two bodies' centres)
  // x1, y1, z1, x2, y2, z2 and the contact's force magnitude, into `chains`; the magnitudes
  // also into `forces`.
  void readChains(std::vector<float>& chains, std::vector<double>& forces) {
    const std::size_t piece = pieceAt();
    const std::string piece_tag = text_.substr(piece, text_.find('>', piece) - piece);
    const long n = count(piece_tag, "NumberOfPoints");
    std::vector<double> points, force;
    std::vector<int> lines, offsets;
    array("points", points, 3 * n, piece);
    array("force", force, 3 * n, piece);
    cells("Lines", lines, offsets, n, count(piece_tag, "NumberOfLines"));
    for (int k = 0; k < static_cast<int>(offsets.size()); ++k)
      if (offsets[k] != 2 * (k + 1)) fail("Lines", "must hold two points per line");
    for (double x : points)
      if (!std::isfinite(x)) fail("points", "holds a value that is not finite");
    for (std::size_t l = 0; l < offsets.size(); ++l) {
      const int a = lines[2 * l], b = lines[2 * l + 1];
      for (int point : {a, b})
        for (int i = 0; i < 3; ++i) chains.push_back(static_cast<float>(points[3 * point + i]));
      const double magnitude = norm3(force, a);
      if (!std::isfinite(magnitude)) fail("force", "holds a value that is not finite");
      chains.push_back(static_cast<float>(magnitude));
      forces.push_back(magnitude);
    }
  }

 private:
  // where the PolyData's piece starts
  std::size_t pieceAt() const {
    const std::size_t piece = text_.find("<Piece ");
    if (text_.find("<VTKFile type=\"PolyData\"") == std::string::npos || piece == std::string::npos)
      fail("VTKFile", "is not a PolyData file");
    return piece;
  }

  [[noreturn]] void fail(const std::string& field, const std::string& message) const {
    throw InputError(file_ + ": " + field + ": " + message);
  }

  long count(const std::string& tag, const std::string& name) const {
    const std::string value = attribute(tag, name);
    char* end = nullptr;
    const long n = std::strtol(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || n < 0 || n > 100000000)
      fail(name, "must be a count in [0, 10^8], got '" + value + "'");
    return n;
  }

  template <class T>
  void readArray(std::size_t name_at, const std::string& name, std::vector<T>& out) const {
    const std::size_t open = text_.rfind('<', name_at);
    const std::size_t begin = text_.find('>', name_at);
    const std::size_t end = text_.find("</DataArray>", name_at);
    if (open == std::string::npos || begin == std::string::npos || end == std::string::npos ||
        end < begin)
      fail(name, "DataArray is not closed");
    if (attribute(text_.substr(open, begin - open), "format") != "ascii")
      fail(name, "must be an ascii DataArray");
    const char* p = text_.c_str() + begin + 1;
    const char* stop = text_.c_str() + end;
    out.clear();
    while (p < stop) {
      while (p < stop && std::isspace(static_cast<unsigned char>(*p))) ++p;
      if (p >= stop) break;
      char* next = nullptr;
      const double x = std::strtod(p, &next);
      if (next == p || next > stop) fail(name, "holds a value that is not a number");
      if constexpr (std::is_integral_v<T>) {
        if (x != std::floor(x) || std::fabs(x) > 1e9)
          fail(name, "holds a value that is not an integer");
      }
      out.push_back(static_cast<T>(x));
      p = next;
    }
  }

  template <class T>
  void array(const std::string& name, std::vector<T>& out, long expected, std::size_t from) const {
    const std::size_t at = text_.find("Name=\"" + name + "\"", from);
    if (at == std::string::npos) fail(name, "missing");
    readArray(at, name, out);
    if (static_cast<long>(out.size()) != expected)
      fail(name,
           "holds " + std::to_string(out.size()) + " values, expected " + std::to_string(expected));
  }

  void cells(const std::string& tag, std::vector<int>& connectivity, std::vector<int>& offsets,
             long points, long cells) const {
    const std::size_t begin = text_.find("<" + tag + ">");
    const std::size_t end = text_.find("</" + tag + ">");
    if (begin == std::string::npos || end == std::string::npos || end < begin) {
      if (cells == 0) return;
      fail(tag, "missing");
    }
    const std::size_t c = text_.find("Name=\"connectivity\"", begin);
    const std::size_t o = text_.find("Name=\"offsets\"", begin);
    if (c == std::string::npos || c > end || o == std::string::npos || o > end)
      fail(tag, "connectivity or offsets missing");
    readArray(c, tag + " connectivity", connectivity);
    readArray(o, tag + " offsets", offsets);
    if (static_cast<long>(offsets.size()) != cells)
      fail(tag,
           "has " + std::to_string(offsets.size()) + " offsets, expected " + std::to_string(cells));
    int previous = 0;
    for (int offset : offsets) {
      if (offset <= previous) fail(tag + " offsets", "must increase");
      previous = offset;
    }
    if (previous != static_cast<int>(connectivity.size()))
      fail(tag + " offsets", "must end at the connectivity's size");
    for (int k : connectivity)
      if (k < 0 || k >= points) fail(tag + " connectivity", "names a point that does not exist");
  }

  std::string file_, text_;
};

// Base64 of the bytes of a float or int array (the page decodes it into a typed array).
template <class T>
std::string base64(const std::vector<T>& values) {
  static const char* const table =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* bytes = reinterpret_cast<const unsigned char*>(values.data());
  const std::size_t n = values.size() * sizeof(T);
  std::string out;
  out.reserve(4 * ((n + 2) / 3));
  for (std::size_t i = 0; i < n; i += 3) {
    const unsigned a = bytes[i], b = i + 1 < n ? bytes[i + 1] : 0, c = i + 2 < n ? bytes[i + 2] : 0;
    out += table[a >> 2];
    out += table[((a & 3) << 4) | (b >> 4)];
    out += i + 1 < n ? table[((b & 15) << 2) | (c >> 6)] : '=';
    out += i + 2 < n ? table[c & 63] : '=';
  }
  return out;
}

// A snapshot as the page draws it: per vertex cell (x, y, z, r, speed, force, kind); per line
// (x1, y1, z1, x2, y2, z2, r, speed, force, kind, shape); per polygon its vertex count and per
// vertex (x, y, z, speed, force, kind); per plane (the snapshot's square of it, drawn see-through
// so that a wall does not hide the scene) its four corners' x, y, z.
struct Frame {
  std::vector<float> balls, lines, polygon_vertices, planes;
  std::vector<std::int32_t> polygon_sizes;
};

// Planes and half-planes are drawn at the size of the other shapes: they do not set the bounds
// the camera fits.
bool unboundedShape(int shape) {
  return shape == static_cast<int>(ShapeType::HalfSpace) ||
         shape == static_cast<int>(ShapeType::HalfPlane);
}

Frame frameOf(const Snapshot& s, std::vector<double>& speeds, std::vector<double>& forces,
              double bounds[6]) {
  Frame f;
  auto point = [&](int k, std::vector<float>& out) {
    const bool measured = !unboundedShape(s.shape[k]);
    for (int i = 0; i < 3; ++i) {
      out.push_back(static_cast<float>(s.points[3 * k + i]));
      if (!measured) continue;
      bounds[i] = std::min(bounds[i], s.points[3 * k + i] - s.radius[k]);
      bounds[3 + i] = std::max(bounds[3 + i], s.points[3 * k + i] + s.radius[k]);
    }
  };
  auto fields = [&](int k, std::vector<float>& out) {
    const double speed = norm3(s.velocity, k), force = norm3(s.force, k);
    out.push_back(static_cast<float>(speed));
    out.push_back(static_cast<float>(force));
    out.push_back(static_cast<float>(s.kind[k]));
    if (s.kind[k] == 1) {
      speeds.push_back(speed);
      forces.push_back(force);
    }
  };
  // a link's collision shapes are not drawn where its visuals are
  auto hidden = [&](int k) { return s.role[k] == kRoleHidden; };
  for (int k : s.verts) {
    if (hidden(k)) continue;
    point(k, f.balls);
    f.balls.push_back(static_cast<float>(s.radius[k]));
    fields(k, f.balls);
  }
  for (std::size_t l = 0; l < s.lines_offsets.size(); ++l) {
    const int a = s.lines[2 * l], b = s.lines[2 * l + 1];
    if (hidden(a)) continue;
    point(a, f.lines);
    point(b, f.lines);
    f.lines.push_back(static_cast<float>(s.radius[a]));
    fields(a, f.lines);
    f.lines.push_back(static_cast<float>(s.shape[a]));
  }
  int begin = 0;
  for (int end : s.polys_offsets) {
    if (s.shape[s.polys[begin]] == static_cast<int>(ShapeType::HalfSpace) && end - begin == 4) {
      for (int i = begin; i < end; ++i) point(s.polys[i], f.planes);
      begin = end;
      continue;
    }
    if (hidden(s.polys[begin])) {
      begin = end;
      continue;
    }
    f.polygon_sizes.push_back(end - begin);
    for (int i = begin; i < end; ++i) {
      point(s.polys[i], f.polygon_vertices);
      fields(s.polys[i], f.polygon_vertices);
    }
    begin = end;
  }
  return f;
}

// The value below which 99 % of the samples lie (the colour scale's top: one body thrown
// out of a pile must not wash out the rest), at least tiny so the scale is never empty.
double scaleTop(std::vector<double>& samples) {
  if (samples.empty()) return 1.0;
  const std::size_t k = std::min(samples.size() - 1, samples.size() * 99 / 100);
  std::nth_element(samples.begin(), samples.begin() + k, samples.end());
  return std::max(samples[k], 1e-12);
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20 || c == '<' || c == '>') {  // nothing can close the script element
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
      out += buffer;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

void replaceOnce(std::string& page, const std::string& marker, const std::string& text) {
  const std::size_t at = page.find(marker);
  if (at == std::string::npos) throw std::logic_error("viewer page without " + marker);
  page.replace(at, marker.size(), text);
}

}  // namespace

int readViewerSnapshot(const std::string& file, const std::string& text) {
  SnapshotReader reader(file, text);
  const Snapshot s = reader.read(0.0);
  std::vector<double> speeds, forces;
  double bounds[6] = {};
  const Frame f = frameOf(s, speeds, forces, bounds);
  return static_cast<int>(f.balls.size() / 7 + f.lines.size() / 11 + f.polygon_sizes.size());
}

namespace {

// The (time, file) entries of a .pvd collection, in order.
std::vector<std::pair<double, std::string>> collectionEntries(const std::filesystem::path& path,
                                                              const std::string& results_dir) {
  namespace fs = std::filesystem;
  const std::string pvd = readWhole(path, kMaxCollectionBytes, "collection");
  std::vector<std::pair<double, std::string>> entries;
  for (std::size_t at = pvd.find("<DataSet "); at != std::string::npos;
       at = pvd.find("<DataSet ", at + 1)) {
    const std::string tag = pvd.substr(at, pvd.find('>', at) - at);
    const std::string time = attribute(tag, "timestep"), file = attribute(tag, "file");
    char* end = nullptr;
    const double t = std::strtod(time.c_str(), &end);
    if (time.empty() || *end != '\0' || !std::isfinite(t))
      throw InputError(path.string() + ": DataSet timestep: must be a number, got '" + time + "'");
    // a Sweep collection names files inside its folder only
    if (file.empty() || fs::path(file).is_absolute() || file.find("..") != std::string::npos)
      throw InputError(path.string() + ": DataSet file: must be a path inside " + results_dir +
                       ", got '" + file + "'");
    entries.emplace_back(t, file);
  }
  if (entries.empty()) throw InputError(path.string() + ": lists no DataSet");
  return entries;
}

// The --every the page is built with, from the first snapshot's frame encoded: the page is
// assembled in about four copies, and each snapshot's dynamic bodies leave two numbers for the
// colour scales.
// The contact network, when there is one, is measured on the last (the first has none).
int pageEvery(const ViewerOptions& options, const std::filesystem::path& dir,
              const std::vector<std::pair<double, std::string>>& entries,
              const std::vector<std::pair<double, std::string>>& networks) {
  const std::string file = (dir / entries.front().second).string();
  SnapshotReader reader(file, readWhole(file, kMaxSnapshotBytes, "snapshot"));
  std::vector<double> speeds, forces;
  double bounds[6] = {0, 0, 0, 0, 0, 0};
  const Frame f = frameOf(reader.read(entries.front().first), speeds, forces, bounds);
  std::vector<float> chains;
  std::vector<double> chain_forces;
  if (!networks.empty()) {
    const std::string last = (dir / networks.back().second).string();
    SnapshotReader(last, readWhole(last, kMaxSnapshotBytes, "contact network"))
        .readChains(chains, chain_forces);
  }
  const double floats =
      static_cast<double>(f.balls.size() + f.lines.size() + f.polygon_sizes.size() +
                          f.polygon_vertices.size() + f.planes.size() + chains.size());
  ViewerPage page;
  page.snapshots = entries.size();
  page.bytes_per_snapshot = 4.0 / 3.0 * 4.0 * floats + 200.0;
  page.memory_per_snapshot =
      4.0 * page.bytes_per_snapshot + 16.0 * speeds.size() + 8.0 * chains.size() / 7;
  page.memory_limit = static_cast<double>(memoryLimitBytes());
  return fittingEvery(page, options.every, options.log);
}

}  // namespace

std::size_t keptSnapshots(std::size_t count, std::size_t every) {
  return (count + every - 1) / every + ((count - 1) % every != 0 ? 1 : 0);
}

int fittingEvery(const ViewerPage& page, int every_given, std::ostream* log) {
  const std::size_t count = page.snapshots;
  const auto fits = [&](std::size_t every) {
    const double kept = static_cast<double>(keptSnapshots(count, every));
    return kept * page.bytes_per_snapshot <= kMaxViewerPageBytes &&
           kept * page.memory_per_snapshot <= page.memory_limit;
  };
  const std::size_t given = every_given > 0 ? static_cast<std::size_t>(every_given) : 1;
  std::size_t smallest = given;
  while (smallest < count && !fits(smallest)) smallest = std::max(smallest + 1, smallest * 5 / 4);
  smallest = std::max(given, std::min(smallest, count));
  if (!fits(smallest))
    throw InputError("one snapshot takes " + formatBytes(page.bytes_per_snapshot) +
                     " of page and " + formatBytes(page.memory_per_snapshot) +
                     " of memory to build: even the first and last alone pass the " +
                     formatBytes(kMaxViewerPageBytes) + " a browser opens or the " +
                     formatBytes(page.memory_limit) + " this process may use");
  // the smallest that fits, not one of the 5/4 steps past it
  while (smallest > given && fits(smallest - 1)) --smallest;
  const std::string sizes =
      std::to_string(count) + " snapshots of " + formatBytes(page.bytes_per_snapshot) + " each";
  if (every_given > 0 && smallest != given)
    throw InputError("--every " + std::to_string(every_given) + ": " + sizes +
                     " make a page past the " + formatBytes(kMaxViewerPageBytes) +
                     " a browser opens or past the " + formatBytes(page.memory_limit) +
                     " this process may use; --every " + std::to_string(smallest) + " fits");
  if (smallest > 1 && log)
    *log << "view: keeping every " << smallest << "-th snapshot (" << keptSnapshots(count, smallest)
         << " of " << sizes << ") so that the page stays within "
         << formatBytes(kMaxViewerPageBytes) << " and this process's memory; --every sets it\n";
  return static_cast<int>(smallest);
}

std::string writeViewer(const ViewerOptions& options) {
  namespace fs = std::filesystem;
  if (options.every < 0)
    throw InputError("--every: must be >= 1, got " + std::to_string(options.every));
  const fs::path dir(options.results_dir);
  const fs::path collection = dir / "snapshots.pvd";
  std::error_code error;
  if (!fs::is_directory(dir, error))
    throw InputError(options.results_dir + ": not a results folder");
  if (!fs::exists(collection, error))
    throw InputError(collection.string() +
                     ": not found; run the scene with output.vtk_interval or output.vtk_every "
                     "set to write snapshots");
  const std::string out =
      options.out_file.empty() ? (dir / "view.html").string() : options.out_file;
  if (fs::is_directory(out, error))
    throw InputError("--out: " + out + " is a folder; the page is one file, e.g. view.html");
  requireOutputFile(out);  // before the page is built, not after
  const fs::path out_folder = fs::absolute(fs::path(out)).parent_path();
  if (!fs::is_directory(out_folder, error))
    throw InputError("--out: " + out + ": the folder " + out_folder.string() + " does not exist");
  const std::vector<std::pair<double, std::string>> entries =
      collectionEntries(collection, options.results_dir);
  // the contact networks beside the snapshots (a run stopped between the two files of a
  // snapshot lists one network fewer: that frame has none)
  std::vector<std::pair<double, std::string>> networks;
  if (fs::exists(dir / "contacts.pvd", error))
    networks = collectionEntries(dir / "contacts.pvd", options.results_dir);

  const std::string three_dir = !options.three_dir.empty() ? options.three_dir
                                : std::getenv("SWEEP_THREE_DIR") != nullptr
                                    ? std::getenv("SWEEP_THREE_DIR")
                                    : "/usr/share/javascript/three";
  const fs::path three = fs::path(three_dir) / "build" / "three.min.js";
  const fs::path controls =
      fs::path(three_dir) / "examples" / "js" / "controls" / "OrbitControls.js";
  for (const fs::path& script : {three, controls})
    if (!fs::is_regular_file(script, error))
      throw InputError(script.string() +
                       ": not found; the viewer inlines three.js from Debian's libjs-three "
                       "(apt-get install libjs-three) or from $SWEEP_THREE_DIR");

  const int every = pageEvery(options, dir, entries, networks);
  std::vector<double> speeds, forces, chain_forces;
  double bounds[6] = {
      std::numeric_limits<double>::infinity(),  std::numeric_limits<double>::infinity(),
      std::numeric_limits<double>::infinity(),  -std::numeric_limits<double>::infinity(),
      -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  int dimension = 0;
  bool any_z = false;
  std::vector<double> up = {0.0, 0.0, 1.0};
  std::ostringstream frames;
  frames.precision(17);
  frames << "[";
  int kept = 0;
  for (std::size_t e = 0; e < entries.size(); ++e) {
    if (e % every != 0 && e + 1 != entries.size()) continue;
    const fs::path file = dir / entries[e].second;
    SnapshotReader reader(file.string(), readWhole(file, kMaxSnapshotBytes, "snapshot"));
    const Snapshot s = reader.read(entries[e].first);
    if (s.dimension != 0) dimension = s.dimension;
    const double g = s.gravity.empty()
                         ? 0.0
                         : std::sqrt(s.gravity[0] * s.gravity[0] + s.gravity[1] * s.gravity[1] +
                                     s.gravity[2] * s.gravity[2]);
    if (g > 0.0) up = {-s.gravity[0] / g, -s.gravity[1] / g, -s.gravity[2] / g};
    for (std::size_t k = 2; k < s.points.size(); k += 3) any_z = any_z || s.points[k] != 0.0;
    const Frame f = frameOf(s, speeds, forces, bounds);
    std::vector<float> chains;
    if (e < networks.size()) {
      const fs::path network = dir / networks[e].second;
      SnapshotReader(network.string(), readWhole(network, kMaxSnapshotBytes, "contact network"))
          .readChains(chains, chain_forces);
    }
    frames << (kept++ ? ",\n" : "") << "{\"t\":" << s.time << ",\"balls\":\"" << base64(f.balls)
           << "\",\"lines\":\"" << base64(f.lines) << "\",\"polygon_sizes\":\""
           << base64(f.polygon_sizes) << "\",\"polygon_vertices\":\"" << base64(f.polygon_vertices)
           << "\",\"planes\":\"" << base64(f.planes) << "\",\"chains\":\"" << base64(chains)
           << "\"}";
  }
  frames << "]";
  if (dimension == 0) dimension = any_z ? 3 : 2;
  if (!(bounds[0] <= bounds[3])) std::fill(bounds, bounds + 6, 0.0);

  std::ostringstream data;
  data.precision(9);
  data << "{\"title\":" << jsonString(fs::absolute(dir).filename().string())
       << ",\"dimension\":" << dimension << ",\"up\":[" << up[0] << "," << up[1] << "," << up[2]
       << "],\"bounds\":[" << bounds[0];
  for (int i = 1; i < 6; ++i) data << "," << bounds[i];
  const bool any_chains = !chain_forces.empty();
  data << "],\"speed_top\":" << scaleTop(speeds) << ",\"force_top\":" << scaleTop(forces)
       << ",\"chains\":" << (any_chains ? "true" : "false")
       << ",\"chain_top\":" << scaleTop(chain_forces) << ",\"frames\":" << frames.str() << "}";

  std::string page = kViewerPage;
  replaceOnce(page, "/*SWEEP_THREE*/", readWhole(three, kMaxCollectionBytes, "three.js"));
  replaceOnce(page, "/*SWEEP_CONTROLS*/",
              readWhole(controls, kMaxCollectionBytes, "OrbitControls"));
  replaceOnce(page, "/*SWEEP_DATA*/", data.str());
  writeFileAtomically(out, page);
  return out;
}

}  // namespace sweep
