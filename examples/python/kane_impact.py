#!/usr/bin/python3
"""V8, the Kane impact, as a runnable system by its equations: M = I on R^2, one constraint
q_0 >= 0 with W_N = (1, 0) and a tangent W_T = (0.9, sqrt(0.19)) that is not M-orthogonal to
it, mu = 0.5, e = 1, hit at U_N = U_T = -1. Jean-Moreau's coupled Coulomb impact gains
kinetic energy (+0.4959); the staggered scheme's does not (docs/validation.md, V8). From a
built tree:

  PYTHONPATH=build/python /usr/bin/python3 examples/python/kane_impact.py
"""
import numpy as np

import sweep


def impact(scheme):
    system = sweep.System("kane", 2, 2, mass=lambda q: np.eye(2), constant_mass=True)
    wall = sweep.Constraint("wall", gap=lambda q: q[0], normal=lambda q: np.array([1.0, 0.0]),
                            tangent=lambda q: np.array([0.9, np.sqrt(0.19)]), friction=0.5,
                            restitution=1.0)
    v_minus = np.array([-1.0, -0.1 / np.sqrt(0.19)])  # U_N = U_T = -1
    sim = sweep.Simulation.from_equations([system], [wall], q0=np.zeros(2), v0=v_minus, dt=1e-3,
                                          scheme=scheme)
    sim.step()
    v = np.array(sim.v)
    return v, 0.5 * v @ v - 0.5 * v_minus @ v_minus, sim.constraint_impulses()[0]


def main():
    for scheme in ("moreau-jean", "catching-up"):
        v, gain, impulse = impact(scheme)
        print(f"{scheme}: v+ = ({v[0]:.5f}, {v[1]:.5f}), kinetic energy change {gain:+.4f} J, "
              f"impulse (normal, tangent) = ({impulse[0]:.4f}, {impulse[1]:.4f})")


if __name__ == "__main__":
    main()
