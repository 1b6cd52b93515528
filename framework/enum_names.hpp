#pragma once
// One table per enum of the scene surface: its values and their names. Scene parsing,
// `sweep export`, the Python module, the messages and docs/cli.md all read the same table, so
// a name cannot drift between them (MuJoCo's mjxmacro.h plays this part there). An enum opts
// in with a specialisation of EnumNames next to its declaration, its names in the order the
// messages list them:
//   template <>
//   struct EnumNames<NormalLaw> {
//     static constexpr EnumName<NormalLaw> table[] = {
//         {NormalLaw::Vel, "vel"}, {NormalLaw::Iqs, "iqs"}, {NormalLaw::Pos, "pos"}};
//   };
#include <optional>
#include <string>
#include <string_view>

namespace sweep {

template <class E>
struct EnumName {
  E value;
  const char* name;
};

template <class E>
struct EnumNames;  // specialised per enum

template <class E>
const char* enumName(E value) {
  for (const EnumName<E>& entry : EnumNames<E>::table)
    if (entry.value == value) return entry.name;
  return "?";
}

template <class E>
std::optional<E> enumFromName(std::string_view name) {
  for (const EnumName<E>& entry : EnumNames<E>::table)
    if (name == entry.name) return entry.value;
  return std::nullopt;
}

// The legal names for a message: "a, b or c"
template <class E>
std::string enumChoices() {
  std::string out;
  const auto& table = EnumNames<E>::table;
  const std::size_t count = sizeof(table) / sizeof(table[0]);
  for (std::size_t i = 0; i < count; ++i) {
    if (i > 0) out += i + 1 == count ? " or " : ", ";
    out += table[i].name;
  }
  return out;
}

}  // namespace sweep
