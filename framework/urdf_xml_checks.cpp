#include "framework/urdf_xml_checks.hpp"

#include <tinyxml.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <vector>

#include "framework/error.hpp"

namespace sweep {

namespace {

// TinyXML (2.6.2, Debian 12) steps over a UTF-8 character by its lead byte's length without
// looking at the bytes it skips: a lead byte that promises more bytes than the text holds
// makes it read past the terminator (found by the URDF fuzzer). XML is UTF-8 unless declared
// otherwise, and URDF files are, so the text is checked byte by byte before any parser sees it.
void requireUtf8(const std::string& xml, const std::string& source) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(xml.data());
  const std::size_t size = xml.size();
  std::size_t i = 0;
  while (i < size) {
    const unsigned char lead = bytes[i];
    int length = 0;
    unsigned minimum = 0;
    if (lead < 0x80)
      length = 1;
    else if (lead >= 0xC2 && lead <= 0xDF)
      length = 2, minimum = 0x80;
    else if (lead >= 0xE0 && lead <= 0xEF)
      length = 3, minimum = 0x800;
    else if (lead >= 0xF0 && lead <= 0xF4)
      length = 4, minimum = 0x10000;
    bool valid = length > 0 && i + length <= size;
    unsigned code = length <= 1 ? lead : lead & (0x3F >> (length - 1));
    for (int k = 1; valid && k < length; ++k) {
      valid = (bytes[i + k] & 0xC0) == 0x80;
      code = (code << 6) | (bytes[i + k] & 0x3F);
    }
    // overlong forms, UTF-16 surrogates and code points past U+10FFFF are not UTF-8 either
    valid = valid && (length == 1 || code >= minimum) && !(code >= 0xD800 && code <= 0xDFFF) &&
            code <= 0x10FFFF;
    if (!valid) {
      const auto line = 1 + std::count(xml.begin(), xml.begin() + static_cast<long>(i), '\n');
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02X", lead);
      throw InputError(source + ": line " + std::to_string(line) + ": not valid UTF-8 (byte " +
                       hex + " at offset " + std::to_string(i) + "); URDF files are read as UTF-8");
    }
    i += static_cast<std::size_t>(length);
  }
}

// TinyXML parses (and frees) nested elements recursively, once per level: 300 000 nested
// elements overflow the call stack. A URDF nests 4 or 5 levels deep, so the nesting is counted
// before any parser sees the text and refused past kMaxXmlDepth. The count skips comments,
// CDATA, declarations and quoted attribute values, whose '<' and '>' are not tags.
constexpr int kMaxXmlDepth = 100;

void requireShallowXml(const std::string& xml, const std::string& source) {
  int depth = 0;
  std::size_t i = 0;
  const std::size_t size = xml.size();
  auto skipPast = [&](const char* end) {
    const std::size_t found = xml.find(end, i);
    i = found == std::string::npos ? size : found + std::strlen(end);
  };
  while ((i = xml.find('<', i)) != std::string::npos) {
    if (xml.compare(i, 4, "<!--") == 0) {
      skipPast("-->");
    } else if (xml.compare(i, 9, "<![CDATA[") == 0) {
      skipPast("]]>");
    } else if (xml.compare(i, 2, "<?") == 0) {
      skipPast("?>");
    } else if (xml.compare(i, 2, "<!") == 0) {
      skipPast(">");
    } else if (xml.compare(i, 2, "</") == 0) {
      --depth;
      skipPast(">");
    } else {
      const std::size_t open = i;
      char quote = 0;
      for (++i; i < size; ++i) {
        const char c = xml[i];
        if (quote) {
          if (c == quote) quote = 0;
        } else if (c == '"' || c == '\'') {
          quote = c;
        } else if (c == '>') {
          break;
        }
      }
      const bool empty_element = i < size && xml[i - 1] == '/';
      if (!empty_element && ++depth > kMaxXmlDepth) {
        const auto line = 1 + std::count(xml.begin(), xml.begin() + static_cast<long>(open), '\n');
        throw InputError(source + ": line " + std::to_string(line) +
                         ": elements nested more than " + std::to_string(kMaxXmlDepth) +
                         " levels deep; a URDF nests about 5 (robot, link, visual, geometry, box)");
      }
      ++i;
    }
  }
}

}  // namespace

// Checks urdfdom does not make, or reports less precisely: XML syntax with its line, a link
// claimed as the child of two joints (urdfdom only sees "two root links" then), and joints
// that form a loop (urdfdom's tree would then hold itself through shared pointers and leak).
// Returns which bounds each joint's <limit> writes, which urdfdom does not tell.
std::map<std::string, LimitAttributes> precheckXml(const std::string& xml,
                                                   const std::string& source) {
  requireUtf8(xml, source);
  requireShallowXml(xml, source);
  TiXmlDocument doc;
  doc.Parse(xml.c_str());
  if (doc.Error())
    throw InputError(source + ": line " + std::to_string(doc.ErrorRow()) + ", column " +
                     std::to_string(doc.ErrorCol()) + ": malformed XML: " + doc.ErrorDesc());
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (!robot) throw InputError(source + ": not a valid URDF: no <robot> element");
  std::map<std::string, std::string> parent_joint, parent_link;
  std::map<std::string, LimitAttributes> limit_attributes;
  for (const TiXmlElement* j = robot->FirstChildElement("joint"); j;
       j = j->NextSiblingElement("joint")) {
    const TiXmlElement* limit = j->FirstChildElement("limit");
    if (limit && j->Attribute("name"))
      limit_attributes[j->Attribute("name")] = {limit->Attribute("lower") != nullptr,
                                                limit->Attribute("upper") != nullptr};
    const TiXmlElement* child = j->FirstChildElement("child");
    const TiXmlElement* parent = j->FirstChildElement("parent");
    const char* link = child ? child->Attribute("link") : nullptr;
    const char* above = parent ? parent->Attribute("link") : nullptr;
    const char* name = j->Attribute("name");
    if (!link || !name) continue;  // urdfdom names the missing part
    const auto [it, fresh] = parent_joint.emplace(link, name);
    if (!fresh)
      throw InputError(source + ": link '" + link +
                       "' has two parents: it is the child of joints '" + it->second + "' and '" +
                       name + "'");
    if (above) parent_link.emplace(link, above);
  }
  // every link has at most one parent now: walking up from each one must end. A link whose
  // ancestry is known to end is marked, so that each link is walked once (a chain of 10^5 links
  // is checked in linear time).
  enum class Walk : char { Unseen, OnPath, Ends };
  std::map<std::string, Walk> state;
  std::vector<const std::string*> path;
  for (const auto& entry : parent_link) {
    path.clear();
    const std::string* at = &entry.first;
    while (true) {
      Walk& mark = state[*at];
      if (mark == Walk::Ends) break;
      if (mark == Walk::OnPath)
        throw InputError(source + ": joint '" + parent_joint.at(*at) + "' closes a loop: link '" +
                         *at + "' is its own ancestor");
      mark = Walk::OnPath;
      path.push_back(at);
      const auto up = parent_link.find(*at);
      if (up == parent_link.end()) break;
      at = &up->second;
    }
    for (const std::string* link : path) state[*link] = Walk::Ends;
  }
  return limit_attributes;
}

}  // namespace sweep
