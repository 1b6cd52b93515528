#pragma once
// Inverse dynamics by the recursive Newton-Euler algorithm (Featherstone 2008, Table 5.1):
// tau = M(q) a + C(q, v) v + g(q), gravity entering as a fictitious base acceleration.
#include "framework/data.hpp"

namespace sweep {

// Both functions return a reference to data.tau: copy the result before the next call (two
// calls inside one expression alias each other).
//
// data.tau = M(q) a + b(q, v); also leaves body velocities and poses in data.
const VectorX& rnea(const Model& model, Data& data, const VectorX& q, const VectorX& v,
                    const VectorX& a);

// data.tau = b(q, v) = Coriolis + centrifugal + gyroscopic + gravity generalized forces.
const VectorX& biasForces(const Model& model, Data& data, const VectorX& q, const VectorX& v);
// data.tau = g(q), the generalized gravity forces (b at v = 0).
const VectorX& gravityForces(const Model& model, Data& data, const VectorX& q);
// data.tau = C(q, v) v, the Coriolis, centrifugal and gyroscopic forces, computed without
// gravity: b - g would lose the digits gravity's larger terms carry.
const VectorX& coriolisForces(const Model& model, Data& data, const VectorX& q, const VectorX& v);
// The same on the kinematics data already holds (forwardKinematics(q, v) just called).
const VectorX& biasForcesFromKinematics(const Model& model, Data& data, const VectorX& v);

// What a time step needs at one configuration, with one kinematic pass: poses, velocities,
// the q-dependent mass blocks (data.mass_blocks) and the bias b(q, v) (data.tau).
void computeAllTerms(const Model& model, Data& data, const VectorX& q, const VectorX& v);

}  // namespace sweep
