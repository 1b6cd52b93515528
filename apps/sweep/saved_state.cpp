// Saved states (final_state.csv) read back and checked as a scene's initial state is.
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "apps/sweep/run.hpp"
#include "apps/sweep/yaml_field.hpp"
#include "framework/error.hpp"

namespace sweep {

namespace {

namespace fs = std::filesystem;

// A saved state is checked as a scene is: coordinates within kMaxCoordinate, unit quaternions,
// and no deep overlap. A state written by a run holds the penetrations the scheme left, far
// below a tenth of a body's size.
constexpr double kMaxStateRelativeOverlap = 0.1;

}  // namespace

SavedState readSavedState(const std::string& path, const Scene& scene, double max_overlap) {
  std::error_code error;
  if (fs::is_directory(path, error))
    throw InputError(path + ": is a folder; a saved state is a final_state.csv file");
  if (!fs::is_regular_file(path, error))
    throw InputError(path + ": saved state does not exist or is not a regular file");
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(path + ": cannot open the saved state");
  std::ostringstream text;
  text << file.rdbuf();
  return readSavedStateText(text.str(), path, scene, max_overlap);
}

void checkState(const Scene& scene, const SavedState& state, double max_overlap,
                const std::string& path) {
  const Model& model = scene.model;
  // every entry, a system's by its equations too (the bounds below go body by body)
  for (const auto& [name, values] :
       {std::pair<const char*, const VectorX&>{"q", state.q}, {"v", state.v}})
    for (Eigen::Index i = 0; i < values.size(); ++i)
      if (!std::isfinite(values[i]))
        throw InputError(path + ": " + name + "[" + std::to_string(i) +
                         "] = " + exactNumber(values[i]) + " is not finite");
  if (!(state.t >= 0.0))
    throw InputError(path + ": t = " + exactNumber(state.t) +
                     " s is before the scene's start (t = 0)");
  for (const Body& body : model.bodies) {
    for (int k = 0; k < body.joint.nq(); ++k) {
      const double x = state.q[body.q_index + k];
      if (std::abs(x) > kMaxCoordinate)
        throw InputError(path + ": q[" + std::to_string(body.q_index + k) +
                         "] = " + exactNumber(x) + " (body '" + body.name + "') is beyond " +
                         formatValue(kMaxCoordinate) +
                         " (m or rad): no contact could be resolved at that distance");
    }
    for (int k = 0; k < body.joint.nv(); ++k) {
      const double x = state.v[body.v_index + k];
      if (std::abs(x) > kMaxSpeed)
        throw InputError(path + ": v[" + std::to_string(body.v_index + k) +
                         "] = " + exactNumber(x) + " (body '" + body.name + "') is beyond " +
                         formatValue(kMaxSpeed) + " (m/s or rad/s)");
    }
    if (body.joint.type != JointType::Floating) continue;
    const double norm = state.q.segment<4>(body.q_index + 3).norm();
    if (!(std::abs(norm - 1.0) <= 1e-6))
      throw InputError(path + ": q[" + std::to_string(body.q_index + 3) + ".." +
                       std::to_string(body.q_index + 6) + "] (body '" + body.name +
                       "'): the orientation quaternion has norm " + exactNumber(norm) + ", not 1");
  }
  rejectBrokenJoints(scene.model, state.q, kMaxStateJointViolation, path,
                     "at the saved state's t = " + exactNumber(state.t) + " s");
  if (max_overlap >= 0.0)
    rejectOverlaps(scene, state.t, state.q, state.v, max_overlap, kMaxStateRelativeOverlap, path,
                   "at the saved state's t = " + exactNumber(state.t) + " s");
}

SavedState readSavedStateText(const std::string& text, const std::string& path, const Scene& scene,
                              double max_overlap) {
  const Model& model = scene.model;
  std::istringstream in(text);
  SavedState state;
  state.q = VectorX::Constant(model.nq, std::nan(""));
  state.v = VectorX::Constant(model.nv, std::nan(""));
  std::vector<char> seen_q(model.nq, 0), seen_v(model.nv, 0);
  char seen_t = 0;
  std::string line;
  int number = 0;
  auto fail = [&](const std::string& what) {
    throw InputError(path + ":" + std::to_string(number) + ": " + what);
  };
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (number == 1) {
      if (line != "vector,index,value")
        fail("expected the header 'vector,index,value' of a final_state.csv, got '" +
             line.substr(0, 80) + "'");
      continue;
    }
    if (line.empty()) continue;
    std::istringstream row(line);
    std::string kind, index_text, value_text;
    if (!std::getline(row, kind, ',') || !std::getline(row, index_text, ',') ||
        !std::getline(row, value_text))
      fail("expected 'vector,index,value', got '" + line.substr(0, 80) + "'");
    std::size_t used = 0;
    long index = -1;
    double value = 0.0;
    try {
      index = std::stol(index_text, &used);
      if (used != index_text.size()) index = -1;
      // strtod, not stod: stod refuses a subnormal value (1e-310), which a run may write
      errno = 0;
      char* end = nullptr;
      value = std::strtod(value_text.c_str(), &end);
      if (value_text.empty() || end != value_text.c_str() + value_text.size())
        fail("value '" + clipForMessage(value_text) + "' is not a number");
      if (errno == ERANGE && std::abs(value) > 1.0) value = std::numeric_limits<double>::infinity();
    } catch (const std::logic_error&) {
      fail("'" + line.substr(0, 80) + "' is not 'vector,index,number'");
    }
    if (!std::isfinite(value))
      fail(kind + "[" + clipForMessage(index_text) + "] = " + clipForMessage(value_text) +
           " is not finite");
    const long size = kind == "q" ? model.nq : kind == "v" ? model.nv : kind == "t" ? 1 : -1;
    if (size < 0) fail("vector '" + kind + "' is none of t, q, v");
    if (index < 0 || index >= size)
      fail(kind + " index " + index_text + " is out of range [0, " + std::to_string(size) +
           ") for this scene (nq = " + std::to_string(model.nq) +
           ", nv = " + std::to_string(model.nv) + ")");
    char& seen = kind == "t" ? seen_t : kind == "q" ? seen_q[index] : seen_v[index];
    if (seen) fail(kind + "[" + index_text + "] is given twice");
    seen = 1;
    if (kind == "t")
      state.t = value;
    else if (kind == "q")
      state.q[index] = value;
    else
      state.v[index] = value;
  }
  if (!seen_t)
    throw InputError(path +
                     ": no 't' row (the time of the state, which runs write first; add a row "
                     "'t,0,TIME' after the header)");
  for (int i = 0; i < model.nq; ++i)
    if (!seen_q[i])
      throw InputError(path + ": q[" + std::to_string(i) + "] is missing (the scene has nq = " +
                       std::to_string(model.nq) + ": a state of another scene?)");
  for (int i = 0; i < model.nv; ++i)
    if (!seen_v[i])
      throw InputError(path + ": v[" + std::to_string(i) + "] is missing (the scene has nv = " +
                       std::to_string(model.nv) + ": a state of another scene?)");
  checkState(scene, state, max_overlap, path);
  return state;
}

}  // namespace sweep
