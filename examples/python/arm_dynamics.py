#!/usr/bin/python3
"""A URDF arm's dynamics from Python: the 6-dof arm of examples/archetypes/arm6.urdf falls from
rest under gravity with its joints free, integrated by semi-implicit Euler on
forward_dynamics; the energy it keeps and the joint angles go in one figure. From a built tree:

  PYTHONPATH=build/python /usr/bin/python3 examples/python/arm_dynamics.py arm.png [T_END]
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import sweep  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
URDF = os.path.join(ROOT, "examples", "archetypes", "arm6.urdf")


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "arm.png"
    t_end = float(sys.argv[2]) if len(sys.argv) > 2 else 2.0
    arm = sweep.Model.from_urdf(URDF)
    h = 1e-4
    q = arm.neutral_configuration()
    q[arm.dof_index("joint2")] = 0.3  # start away from the vertical so that it swings
    v = np.zeros(arm.nv)
    zero = np.zeros(arm.nv)
    energy0 = arm.kinetic_energy(q, v) + arm.potential_energy(q)
    times, angles, drift = [], [], []
    for k in range(int(round(t_end / h))):
        v = v + h * arm.forward_dynamics(q, v, zero)
        q = q + h * v  # revolute joints only: q is a vector space
        if k % 100 == 0:
            times.append((k + 1) * h)
            angles.append(q.copy())
            drift.append(arm.kinetic_energy(q, v) + arm.potential_energy(q) - energy0)
    angles = np.array(angles)
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for j, name in enumerate(arm.dof_names):
        top.plot(times, angles[:, j], label=name)
    top.set_ylabel("joint angle (rad)")
    top.legend(ncol=3, fontsize=8)
    bottom.plot(times, drift)
    bottom.set_ylabel("energy drift (J)")
    bottom.set_xlabel("t (s)")
    figure.tight_layout()
    figure.savefig(out, dpi=120)
    print(f"wrote {out}; energy drift at the end {drift[-1]:.3e} J of {energy0:.3f} J")


if __name__ == "__main__":
    main()
