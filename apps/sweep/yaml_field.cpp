#include "apps/sweep/yaml_field.hpp"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>

#include <vector>

#include <sstream>

#include <map>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "framework/error.hpp"

namespace sweep {

YamlField YamlField::operator[](const std::string& key) const {
  requireMap();
  return YamlField(node_[key], file_, path_.empty() ? key : path_ + "." + key);
}

YamlField YamlField::at(std::size_t index) const {
  return YamlField(node_[index], file_, path_ + "[" + std::to_string(index) + "]");
}

std::vector<std::string> YamlField::keys() const {
  requireMap();
  std::vector<std::string> out;
  for (const auto& entry : node_) out.push_back(entry.first.as<std::string>());
  return out;
}

std::string clipForMessage(const std::string& text) {
  // a message quotes a value, it does not reproduce a 50 MB one
  constexpr std::size_t kShown = 120;
  if (text.size() <= kShown) return text;
  return text.substr(0, kShown) + "... (" + std::to_string(text.size()) + " characters)";
}

std::string YamlField::quoted() const {
  if (!node_.IsDefined() || node_.IsNull()) return "nothing";
  if (node_.IsScalar()) return clipForMessage(node_.Scalar());
  YAML::Emitter out;
  out << YAML::Flow << node_;
  return clipForMessage(out.c_str());
}

void YamlField::fail(const std::string& rule) const {
  throw InputError(file_ + ": " + (path_.empty() ? "top level" : path_) + ": " + rule + ", got " +
                   quoted());
}

const YamlField& YamlField::requireMap() const {
  if (!node_.IsMap()) fail("must be a map of key: value");
  return *this;
}

const YamlField& YamlField::requireSequence() const {
  if (!node_.IsSequence()) fail("must be a list");
  return *this;
}

void YamlField::allowOnly(std::initializer_list<const char*> allowed) const {
  requireMap();
  for (const std::string& key : keys()) {
    bool known = false;
    for (const char* a : allowed) known = known || key == a;
    if (known) continue;
    std::string list;
    for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
    throw InputError(file_ + ": " + (path_.empty() ? "" : path_ + ".") + clipForMessage(key) +
                     ": unknown key (expected one of: " + list + ")");
  }
}

double YamlField::number() const {
  if (!node_.IsScalar()) fail("must be a number");
  const std::string& s = node_.Scalar();
  errno = 0;
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size()) fail("must be a number");
  // strtod flags a subnormal result (1e-310) with ERANGE too: it is a number Sweep can write
  // in a saved state, so only an overflow is refused
  if (errno == ERANGE && std::abs(x) > 1.0) fail("must be finite (it overflows a double)");
  if (!std::isfinite(x)) fail("must be finite");
  return x;
}

double YamlField::positive() const {
  const double x = number();
  if (!(x > 0.0)) fail("must be > 0");
  return x;
}

double YamlField::nonNegative() const {
  const double x = number();
  if (!(x >= 0.0)) fail("must be >= 0");
  return x;
}

long YamlField::integer() const {
  if (!node_.IsScalar()) fail("must be an integer");
  const std::string& s = node_.Scalar();
  errno = 0;
  char* end = nullptr;
  const long x = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE) fail("must be an integer");
  return x;
}

std::optional<bool> YamlField::asBoolean() const {
  if (node_.IsScalar()) {
    const std::string& s = node_.Scalar();
    if (s == "true" || s == "yes" || s == "on") return true;
    if (s == "false" || s == "no" || s == "off") return false;
  }
  return std::nullopt;
}

bool YamlField::boolean() const {
  const std::optional<bool> flag = asBoolean();
  if (!flag) fail("must be true or false");
  return *flag;
}

std::string YamlField::text() const {
  if (!node_.IsScalar()) fail("must be a string");
  return node_.Scalar();
}

std::vector<double> YamlField::numbers() const {
  requireSequence();
  std::vector<double> out;
  for (std::size_t i = 0; i < size(); ++i) out.push_back(at(i).number());
  return out;
}

Vector3 YamlField::vector(int dimension) const {
  if (!node_.IsSequence() || !(node_.size() == static_cast<std::size_t>(dimension)))
    fail("must be a list of " + std::to_string(dimension) + " numbers");
  Vector3 v = Vector3::Zero();
  for (int k = 0; k < dimension; ++k) v[k] = at(k).number();
  return v;
}

double YamlField::number(const std::string& key, double fallback) const {
  return has(key) ? (*this)[key].number() : fallback;
}
double YamlField::positive(const std::string& key, double fallback) const {
  return has(key) ? (*this)[key].positive() : fallback;
}
double YamlField::nonNegative(const std::string& key, double fallback) const {
  return has(key) ? (*this)[key].nonNegative() : fallback;
}
long YamlField::integer(const std::string& key, long fallback) const {
  return has(key) ? (*this)[key].integer() : fallback;
}
bool YamlField::boolean(const std::string& key, bool fallback) const {
  return has(key) ? (*this)[key].boolean() : fallback;
}
std::string YamlField::text(const std::string& key, const std::string& fallback) const {
  return has(key) ? (*this)[key].text() : fallback;
}

namespace {

// The written nodes of a document may expand, through aliases, to this many plus ten for each
// written node; a billion-laughs tree of aliases expands to 10^9 from a hundred
constexpr unsigned long long kExpandedBase = 100000, kExpandedPerWritten = 10;

// yaml-cpp keeps every entry of a map, a repeated key too, and its lookup returns the first: a
// scene with `dimension: 2` and later `dimension: 3` would run as 2D without a word. It also
// takes `<<` for an ordinary key. Every map is therefore checked on the parser's events, once
// per written node: an alias is never walked again (a tree of aliases would expand
// exponentially, an alias inside its own anchor forever), only its expanded size is counted.
class StructureCheck : public YAML::EventHandler {
 public:
  explicit StructureCheck(const std::string& path) : path_(path) {}

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnAnchor(const YAML::Mark&, const std::string& name) override { anchor_name_ = name; }
  void OnNull(const YAML::Mark& at, YAML::anchor_t anchor) override {
    leaf(at, anchor, Node{"null", "", "", false, 1});
  }
  void OnScalar(const YAML::Mark& at, const std::string& tag, YAML::anchor_t anchor,
                const std::string& value) override {
    leaf(at, anchor, Node{"a scalar", value, tag, true, 1});
  }
  void OnAlias(const YAML::Mark& at, YAML::anchor_t anchor) override {
    const auto found = anchors_.find(anchor);
    if (found == anchors_.end()) return;  // the parser refuses an unknown anchor itself
    if (found->second.open)
      throw InputError(where(at, nextField()) + "the alias *" + found->second.name +
                       " refers to the node that holds it (a cycle)");
    leaf(at, YAML::NullAnchor, found->second.node);
  }
  void OnSequenceStart(const YAML::Mark& at, const std::string&, YAML::anchor_t anchor,
                       YAML::EmitterStyle::value) override {
    open(at, anchor, false);
  }
  void OnMapStart(const YAML::Mark& at, const std::string&, YAML::anchor_t anchor,
                  YAML::EmitterStyle::value) override {
    open(at, anchor, true);
  }
  void OnSequenceEnd() override { close(); }
  void OnMapEnd() override { close(); }

 private:
  struct Node {
    const char* kind;
    std::string value, tag;  // a scalar's
    bool scalar;
    unsigned long long expanded;  // nodes, aliases expanded
  };
  struct Anchor {
    std::string name;
    Node node;
    bool open;
  };
  struct Frame {
    bool map = false;
    std::string field;
    YAML::anchor_t anchor = YAML::NullAnchor;
    unsigned long long expanded_before = 0;
    bool expect_key = true;
    std::size_t index = 0;
    std::string value_field;
    std::map<std::string, int> lines;
  };

  std::string where(const YAML::Mark& at, const std::string& field) const {
    return path_ + ":" + std::to_string(at.line + 1) + ": " +
           (field.empty() ? std::string() : field + ": ");
  }
  std::string field() const { return stack_.empty() ? std::string() : stack_.back().field; }
  // the field of the node that comes next (a value's or an item's; a key's map)
  std::string nextField() const {
    if (stack_.empty()) return std::string();
    const Frame& top = stack_.back();
    if (!top.map) return top.field + "[" + std::to_string(top.index) + "]";
    return top.expect_key ? top.field : top.value_field;
  }

  // A node's place: a key of the map on top (checked, and no field of its own), a value (the
  // field its key named) or an item. Returns whether it is a key.
  bool place(const YAML::Mark& at, const Node& node, std::string& node_field) {
    if (stack_.empty()) return false;
    Frame& top = stack_.back();
    if (!top.map) {
      node_field = top.field + "[" + std::to_string(top.index++) + "]";
      return false;
    }
    if (!top.expect_key) {
      node_field = top.value_field;
      top.expect_key = true;
      return false;
    }
    if (!node.scalar)
      throw InputError(where(at, top.field) + "a key must be a name, got " + node.kind);
    if (node.value == "<<" && node.tag != "!")
      throw InputError(where(at, top.field) +
                       "YAML merge keys (<<) are not supported: write the entries out");
    top.value_field = top.field.empty() ? node.value : top.field + "." + node.value;
    const auto [seen, fresh] = top.lines.emplace(node.value, at.line + 1);
    if (!fresh)
      throw InputError(where(at, top.value_field) + "given twice (first on line " +
                       std::to_string(seen->second) + ")");
    top.expect_key = false;
    return true;
  }
  void count(const YAML::Mark& at, unsigned long long expanded) {
    const unsigned long long limit = kExpandedBase + kExpandedPerWritten * ++written_;
    expanded_ = std::min(expanded_ + expanded, limit + 1);
    if (expanded_ > limit)
      throw InputError(where(at, field()) + "YAML aliases expand the document past " +
                       std::to_string(limit) + " nodes (" + std::to_string(written_) +
                       " written): an alias may repeat a node, not multiply the document");
  }
  void remember(YAML::anchor_t anchor, const Node& node, bool open) {
    if (anchor == YAML::NullAnchor) return;
    anchors_[anchor] = Anchor{anchor_name_, node, open};
  }
  void leaf(const YAML::Mark& at, YAML::anchor_t anchor, const Node& node) {
    std::string node_field;
    place(at, node, node_field);
    count(at, node.expanded);
    remember(anchor, node, false);
  }
  void open(const YAML::Mark& at, YAML::anchor_t anchor, bool map) {
    std::string node_field;
    place(at, Node{map ? "a map" : "a sequence", "", "", false, 1}, node_field);
    count(at, 1);
    remember(anchor, Node{map ? "a map" : "a sequence", "", "", false, 1}, true);
    Frame frame;
    frame.map = map;
    frame.field = node_field;
    frame.anchor = anchor;
    frame.expanded_before = expanded_ - 1;
    stack_.push_back(std::move(frame));
  }
  void close() {
    const Frame done = std::move(stack_.back());
    stack_.pop_back();
    if (done.anchor == YAML::NullAnchor) return;
    Anchor& anchor = anchors_[done.anchor];
    anchor.node.expanded = expanded_ - done.expanded_before;
    anchor.open = false;
  }

  std::string path_;
  std::vector<Frame> stack_;  // explicit: a nesting of 10^5 levels must not overflow the stack
  std::map<YAML::anchor_t, Anchor> anchors_;
  std::string anchor_name_;
  unsigned long long expanded_ = 0, written_ = 0;
};

}  // namespace

void checkYamlText(const std::string& text, const std::string& path) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  StructureCheck check(path);
  parser.HandleNextDocument(check);
}

namespace {

// Events of a document, kept only for the mark of the first one.
class FirstMark : public YAML::EventHandler {
 public:
  void OnDocumentStart(const YAML::Mark& at) override { note(at); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& at, YAML::anchor_t) override { note(at); }
  void OnAlias(const YAML::Mark& at, YAML::anchor_t) override { note(at); }
  void OnScalar(const YAML::Mark& at, const std::string&, YAML::anchor_t,
                const std::string&) override {
    note(at);
  }
  void OnSequenceStart(const YAML::Mark& at, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    note(at);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& at, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    note(at);
  }
  void OnMapEnd() override {}
  bool seen = false;
  YAML::Mark first;

 private:
  void note(const YAML::Mark& m) {
    if (!seen) first = m;
    seen = true;
  }
};

// Whether the text holds a second YAML document after its first, and where it starts. Load
// reads the first document and ignores the rest; the parser is asked once for a second:
// YAML::LoadAll would loop forever, allocating, on some malformed texts (found by the scene
// fuzzer), because the parser then reports empty documents without end.
bool secondDocument(const std::string& text, YAML::Mark& at) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  FirstMark first, second;
  parser.HandleNextDocument(first);
  if (!parser.HandleNextDocument(second)) return false;
  at = second.first;
  return true;
}

}  // namespace

YAML::Node parseYamlText(const std::string& text, const std::string& path) {
  auto syntaxError = [&](const YAML::Mark& mark, const std::string& what) {
    return InputError(path + ":" + std::to_string(mark.line + 1) + ":" +
                      std::to_string(mark.column + 1) + ": " + what);
  };
  YAML::Node root;
  try {
    root = YAML::Load(text);  // a syntax error first; an alias cycle is built, never walked
    checkYamlText(text, path);
    YAML::Mark second;
    if (secondDocument(text, second))
      throw syntaxError(second,
                        "a second YAML document, or text outside the first, starts here; the "
                        "file must hold one document");
  } catch (const YAML::DeepRecursion& e) {
    // yaml-cpp's depth guard stops a recursion of about 4 calls per level, with "bad file"
    throw syntaxError(e.mark,
                      "YAML nested too deeply (the parser stops at about 500 levels; a scene "
                      "nests about 5)");
  } catch (const YAML::Exception& e) {
    throw syntaxError(e.mark, "YAML syntax error: " + e.msg);
  }
  if (!root.IsDefined() || root.IsNull()) throw InputError(path + ": the file is empty");
  return root;
}

YAML::Node loadYamlFile(const std::string& path) {
  // a device or a fifo (sweep run /dev/zero) would be read forever
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw InputError(path + ": is a folder, not a file");
  if (std::filesystem::exists(path, error) && !std::filesystem::is_regular_file(path, error))
    throw InputError(path + ": not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the file");
  std::ostringstream text;
  text << in.rdbuf();
  return parseYamlText(text.str(), path);
}

FieldOverride parseOverride(const std::string& assignment) {
  const auto equals = assignment.find('=');
  if (equals == std::string::npos || equals == 0)
    throw InputError("--set " + assignment + ": expected path=value, e.g. scheme.h=1e-4");
  FieldOverride result;
  result.path = assignment.substr(0, equals);
  result.origin = "--set " + assignment;
  try {
    const std::string value = assignment.substr(equals + 1);
    result.value = YAML::Load(value);
    checkYamlText(value, "--set " + result.path);
    YAML::Mark second;
    if (secondDocument(value, second))
      throw InputError("--set " + assignment +
                       ": a second YAML document, or text outside the first, starts at "
                       "character " +
                       std::to_string(second.pos + 1) + " of the value; a value is one document");
  } catch (const YAML::Exception& e) {
    throw InputError("--set " + assignment + ": the value is not YAML: " + e.msg);
  }
  return result;
}

std::vector<FieldOverride> loadOverrideFile(const std::string& path) {
  return overridesFromYaml(loadYamlFile(path), path);
}

std::vector<FieldOverride> overridesFromYaml(const YAML::Node& root, const std::string& path) {
  if (!root.IsMap())
    throw InputError(path + ": a settings file is a map of path: value entries (scheme.h: 1e-4)");
  std::vector<FieldOverride> entries;
  for (const auto& entry : root) {
    FieldOverride o;
    if (!entry.first.IsScalar() || entry.first.Scalar().empty())
      throw InputError(path + ":" + std::to_string(entry.first.Mark().line + 1) +
                       ": expected a field path as the key, e.g. scheme.h");
    o.path = entry.first.Scalar();
    o.value = entry.second;
    o.origin = path + ": " + o.path;
    entries.push_back(std::move(o));
  }
  return entries;
}

void applyOverride(YAML::Node& root, const std::string& assignment, const std::string& file) {
  applyOverride(root, parseOverride(assignment), file);
}

void applyOverride(YAML::Node& root, const FieldOverride& override_, const std::string& file) {
  const std::string& path = override_.path;
  const YAML::Node& value = override_.value;
  const std::string& origin = override_.origin;
  // walk with node handles; yaml-cpp's operator= on a handle would rebind it, so descend by
  // reset() and assign the leaf through its parent
  YAML::Node node = root;
  std::size_t start = 0;
  while (true) {
    std::size_t stop = path.find_first_of(".[", start);
    std::string key = path.substr(start, stop - start);
    if (key.empty() && (stop == std::string::npos || path[stop] != '['))
      throw InputError(origin + ": empty field name in '" + path + "'");
    YAML::Node next;
    if (!key.empty()) {
      if (!node.IsMap() && !node.IsNull())
        throw InputError(origin + ": " + file + ": '" + key +
                         "' is inside something that is not a map");
      if (stop == std::string::npos) {
        node[key] = value;
        return;
      }
      // a section the file does not have yet (`--set detection.margin=...` on a scene
      // without `detection:`) is created, as writing it in the file would
      if (path[stop] == '.' && (!node[key] || node[key].IsNull()))
        node[key] = YAML::Node(YAML::NodeType::Map);
      next.reset(node[key]);
      node.reset(next);
    }
    if (path[stop] == '[') {
      const std::size_t close = path.find(']', stop);
      if (close == std::string::npos) throw InputError(origin + ": missing ']' in '" + path + "'");
      const std::string digits = path.substr(stop + 1, close - stop - 1);
      char* end = nullptr;
      const long index = std::strtol(digits.c_str(), &end, 10);
      if (digits.empty() || *end != '\0' || !node.IsSequence() || index < 0 ||
          index >= static_cast<long>(node.size()))
        throw InputError(origin + ": " + file + ": no element [" + digits + "] there");
      if (close + 1 == path.size()) {
        node[index] = value;
        return;
      }
      next.reset(node[index]);
      node.reset(next);
      stop = close + 1;
      if (path[stop] != '.')
        throw InputError(origin + ": expected '.' after ']' in '" + path + "'");
    }
    start = stop + 1;
  }
}

}  // namespace sweep
