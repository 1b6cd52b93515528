#!/usr/bin/python3
"""Painleve's rod in its textbook coordinates, as a system by its equations: q = (x, y, theta),
the centre and the angle to the floor, M = diag(m, m, m l^2 / 3) for half-length l, gravity,
and one constraint, the lower end's height y - l sin(theta) >= 0, with its normal and tangent
as the gradients of the end's height and horizontal position. Sliding at 1 m/s with
tan(theta) = 2 and mu = 1.5, past Painleve's bound: Jean-Moreau jams the end in one step with
an impulse of order one; the staggered scheme slides on (docs/validation.md, V7). From a
built tree:

  PYTHONPATH=build/python /usr/bin/python3 examples/python/painleve_rod.py painleve.png [T_END]
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import sweep  # noqa: E402

M_ROD, L, G, MU = 1.0, 0.5, 9.81, 1.5
THETA = np.arctan(2.0)


def rod():
    system = sweep.System(
        "rod", 3, 3,
        mass=lambda q: np.diag([M_ROD, M_ROD, M_ROD * L * L / 3.0]),
        forces=lambda t, q, v: np.array([0.0, -M_ROD * G, 0.0]),
        potential=lambda q: M_ROD * G * q[1],
        constant_mass=True)
    end = sweep.Constraint(
        "lower end",
        gap=lambda q: q[1] - L * np.sin(q[2]),
        normal=lambda q: np.array([0.0, 1.0, -L * np.cos(q[2])]),
        tangent=lambda q: np.array([1.0, 0.0, L * np.sin(q[2])]),
        friction=MU)
    return system, end


def simulate(scheme, t_end, h=1e-4):
    system, end = rod()
    q0 = np.array([0.0, L * np.sin(THETA), THETA])
    v0 = np.array([-1.0, 0.0, 0.0])
    sim = sweep.Simulation.from_equations([system], [end], q0=q0, v0=v0, dt=h, t_end=t_end,
                                          scheme=scheme)
    times, slip, normal = [], [], []
    for _ in range(int(round(t_end / h))):
        sim.step()
        q, v = sim.q, sim.v
        times.append(sim.t)
        slip.append(v[0] + L * np.sin(q[2]) * v[2])  # the end's horizontal velocity
        normal.append(sim.constraint_impulses()[0, 0])
    return np.array(times), np.array(slip), np.array(normal)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "painleve.png"
    t_end = float(sys.argv[2]) if len(sys.argv) > 2 else 0.05
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for scheme in ("moreau-jean", "catching-up"):
        t, slip, normal = simulate(scheme, t_end)
        top.plot(t, slip, label=scheme)
        bottom.semilogy(t, np.maximum(normal, 1e-12), label=scheme)
        print(f"{scheme}: first-step normal impulse {normal[0]:.4g} N s, "
              f"end's velocity at {t[-1]:.3f} s: {slip[-1]:.4g} m/s")
    top.set_ylabel("lower end's horizontal velocity (m/s)")
    bottom.set_ylabel("normal impulse per step (N s)")
    bottom.set_xlabel("t (s)")
    top.legend()
    figure.tight_layout()
    figure.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
