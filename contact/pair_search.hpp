#pragma once
// Detection's pair search (internal to contact/): the broadphases, which list the pairs of
// geometries whose bounds come within the margins, and their sort into the order of contact
// keys. detection.cpp runs them; pair_search.cpp holds them.
#include <cstddef>
#include <utility>

#include "contact/detection.hpp"

namespace sweep {

// a half-space's or half-plane's outward normal in world coordinates
inline Vector3 outwardNormal(const Shape& s, const Pose& pose) {
  return s.type == ShapeType::HalfSpace ? Vector3(pose.rotation.col(2))
                                        : Vector3(pose.rotation.col(1));
}

// Pairs carry the periodic image of their second geometry in the two low bits of `second`:
// (b << 2) | image, image 0 for b itself, 1 for b shifted by +period, 2 for -period. Sorting
// the encoded pairs sorts by (a, b, image), the order of contact keys.
constexpr int kImageBits = 2;
inline std::pair<int, int> encodePair(int a, int b, int image = 0) {
  return {a, (b << kImageBits) | image};
}
inline int pairGeometry(int encoded) {
  return encoded >> kImageBits;
}
inline int pairImage(int encoded) {
  return encoded & ((1 << kImageBits) - 1);
}

inline Vector3 imageShift(const Periodicity& periodic, int image) {
  Vector3 shift = Vector3::Zero();
  if (image != 0) shift[periodic.axis] = image == 1 ? periodic.period() : -periodic.period();
  return shift;
}

// Whether geometry g belongs to a driven body past its removal time at t (a pulled gate or
// shutter): it then meets nothing.
inline bool removedAt(const Model& model, const ContactModel& cmodel, int g, double t) {
  const BodyRef& body = cmodel.traits[g].body_ref;
  return body.kind == BodyRef::Kind::Driven && !model.driven_bodies[body.index].presentAt(t);
}

// The first of `count` items in run r of `runs` (runs of equal length, in order).
inline std::size_t runBegin(std::size_t count, int r, int runs) {
  return count * static_cast<std::size_t>(r) / static_cast<std::size_t>(runs);
}

// The balls of the grid path (ContactData::particles) by a uniform grid, with the periodic
// images of those near a periodic boundary, and every other geometry against them and each other
// by its bounds.
// Driven bodies past their removal time at t are left out.
void broadphaseGrid(const Model& model, const ContactModel& cmodel, ContactData& cdata,
                    const DetectionMargins& margins, double t, int threads);
// Every pair by FCL's dynamic AABB tree.
void broadphaseFcl(const ContactModel& cmodel, ContactData& cdata, const DetectionMargins& margins);
// cdata.pairs sorted by (a, b, image): the same order on any thread count.
void sortPairs(int geometries, ContactData& cdata, int threads);

}  // namespace sweep
