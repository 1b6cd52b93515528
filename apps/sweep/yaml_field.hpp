#pragma once
// A YAML node that knows where it is: the file and the field path (bodies[3].radius), so that
// every rejection names both and quotes the value as written. Keys a section does not know
// are errors, never ignored.
#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <optional>
#include <string>
#include <vector>

#include "framework/enum_names.hpp"
#include "framework/spatial.hpp"

namespace sweep {

class YamlField {
 public:
  YamlField(YAML::Node node, std::string file, std::string path = "")
      : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  bool isMap() const { return node_.IsMap(); }
  bool isSequence() const { return node_.IsSequence(); }
  bool isScalar() const { return node_.IsScalar(); }
  bool isNull() const { return !node_.IsDefined() || node_.IsNull(); }
  bool has(const std::string& key) const { return node_.IsMap() && node_[key]; }

  YamlField operator[](const std::string& key) const;  // the map's child (maybe absent)
  YamlField at(std::size_t index) const;               // the sequence's element
  std::size_t size() const { return node_.size(); }
  std::vector<std::string> keys() const;  // of a map, in file order

  // Each throws InputError "FILE: PATH: RULE, got VALUE".
  [[noreturn]] void fail(const std::string& rule) const;
  const YamlField& requireMap() const;
  const YamlField& requireSequence() const;
  void allowOnly(std::initializer_list<const char*> keys) const;

  double number() const;  // finite
  double positive() const;
  double nonNegative() const;
  long integer() const;
  bool boolean() const;
  std::optional<bool> asBoolean() const;  // the same without failing: nullopt if not a boolean
  std::string text() const;
  // `dimension` finite components; a 2D scene may give 2 (z = 0)
  Vector3 vector(int dimension) const;
  std::vector<double> numbers() const;

  // Optional children: the fallback when the key is absent.
  double number(const std::string& key, double fallback) const;
  double positive(const std::string& key, double fallback) const;
  double nonNegative(const std::string& key, double fallback) const;
  long integer(const std::string& key, long fallback) const;
  bool boolean(const std::string& key, bool fallback) const;
  std::string text(const std::string& key, const std::string& fallback) const;
  // One of an enum's names (framework/enum_names.hpp): "must be a, b or c" otherwise
  template <class E>
  E choice(const std::string& key, E fallback) const {
    const std::optional<E> value = enumFromName<E>(text(key, enumName(fallback)));
    if (!value) (*this)[key].fail("must be " + enumChoices<E>());
    return *value;
  }

 private:
  std::string quoted() const;  // the value as written, for messages
  YAML::Node node_;
  std::string file_;
  std::string path_;
};

// Parses a YAML file; syntax errors become InputError with line and column.
YAML::Node loadYamlFile(const std::string& path);

// `text` as an error message quotes it: at most 120 characters, then its length.
std::string clipForMessage(const std::string& text);

// YAML text as one document: InputError naming the file and line for a syntax error, an empty
// text, a second document, a key that is not a name, a key given twice in one map, a merge
// key (<<), an alias inside its own anchor, or aliases that multiply the document's size.
YAML::Node parseYamlText(const std::string& text, const std::string& path);

// The key and alias checks of parseYamlText on the text's first document, from the parser's
// events (no node is built); YAML syntax errors are thrown as YAML::Exception.
void checkYamlText(const std::string& text, const std::string& path);

// One field to replace before a scene is parsed: `path` as in messages (scheme.h,
// bodies[2].radius), `value` as YAML, so lists and numbers keep their types, and `origin`,
// where it came from, to start every message about it ("--set scheme.h=1e-4",
// "fast.yaml: scheme.h").
struct FieldOverride {
  std::string path;
  YAML::Node value;
  std::string origin;
};

// `path=value` as `--set` takes it. InputError on a malformed assignment.
FieldOverride parseOverride(const std::string& assignment);

// A settings file for `--set-file`: a YAML map of `path: value` entries, each one `--set`,
// in file order. InputError naming the file (and the entry) when it is missing, not a map,
// or has an empty path.
std::vector<FieldOverride> loadOverrideFile(const std::string& path);
// The same from a parsed document; `path` names the file in messages.
std::vector<FieldOverride> overridesFromYaml(const YAML::Node& root, const std::string& path);

// Replaces the field in a document (the whole field: a map value replaces the section, as
// writing it in the file would). InputError on a path through a non-map or to a missing
// sequence element.
void applyOverride(YAML::Node& root, const FieldOverride& override_, const std::string& file);
void applyOverride(YAML::Node& root, const std::string& assignment, const std::string& file);

}  // namespace sweep
