#pragma once
// The checks a URDF's text passes before urdfdom parses it (internal to framework/): UTF-8 that
// TinyXML can walk, nesting it can recurse through, and what urdfdom does not check or reports
// less precisely (urdf_xml_checks.cpp says which).
#include <map>
#include <string>

namespace sweep {

struct LimitAttributes {
  bool lower = false, upper = false;  // written in the <limit> element
};

// Checks urdfdom does not make, or reports less precisely: XML syntax with its line, a link
// claimed as the child of two joints, and joints that form a loop; throws InputError naming
// `source`. Returns which bounds each joint's <limit> writes, which urdfdom does not tell.
std::map<std::string, LimitAttributes> precheckXml(const std::string& xml,
                                                   const std::string& source);

}  // namespace sweep
