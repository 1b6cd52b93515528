#!/usr/bin/python3
"""The woodpecker toy in the linearized model of Pfeiffer & Glocker (Glocker's thesis, 1995;
Glocker 2001), as a system by its equations next to Sweep's exact-kinematics scene
(examples/archetypes/woodpecker.yaml, docs/validation.md V9).

q = (y, phi_M, phi_S): the sleeve's height, the sleeve's and the bird's angles. M is constant,
the forces are gravity and the rotational spring c_phi (phi_M - phi_S); three unilateral
contacts with Coulomb friction mu = 0.3, linear in q: the beak on the pole (restitution 0.5)
and the sleeve's two edges on the pole. From a built tree:

  PYTHONPATH=build/python /usr/bin/python3 examples/python/woodpecker.py woodpecker.png [T_END]
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import sweep  # noqa: E402

# the published parameters: sleeve (M) and bird (S)
m_M, J_M, m_S, J_S = 3.0e-4, 5.0e-9, 4.5e-3, 7.0e-7  # kg, kg m^2
c_phi, g = 5.6e-3, 9.81  # N m / rad, m / s^2
r_0, r_M, h_M, l_M, l_G, h_S, l_S = 2.5e-3, 3.1e-3, 5.8e-3, 1.0e-2, 1.5e-2, 2.0e-2, 2.01e-2
mu = 0.3
q_start = np.array([0.0, -0.1036, -0.2788])
v_start = np.array([-0.3411, 0.0, -7.4583])

MASS = np.array([[m_S + m_M, m_S * l_M, m_S * l_G],
                 [m_S * l_M, J_M + m_S * l_M**2, m_S * l_M * l_G],
                 [m_S * l_G, m_S * l_M * l_G, J_S + m_S * l_G**2]])


def forces(t, q, v):
    _, phi_M, phi_S = q
    return np.array([-(m_S + m_M) * g,
                     -c_phi * (phi_M - phi_S) - m_S * l_M * g,
                     -c_phi * (phi_S - phi_M) - m_S * l_G * g])


def linear(name, gap0, normal, tangent, restitution=0.0):
    normal, tangent = np.array(normal), np.array(tangent)
    return sweep.Constraint(name, gap=lambda q: gap0 + normal @ q, normal=lambda q: normal,
                            tangent=lambda q: tangent, friction=mu, restitution=restitution)


def woodpecker(scheme, t_end, h=1e-4):
    toy = sweep.System("woodpecker", 3, 3, mass=lambda q: MASS, forces=forces,
                       constant_mass=True)
    contacts = [
        linear("beak", l_M + l_G - l_S - r_0, [0.0, 0.0, -h_S], [1.0, l_M, l_G - l_S], 0.5),
        linear("sleeve, upper edge", r_M - r_0, [0.0, h_M, 0.0], [1.0, r_M, 0.0]),
        linear("sleeve, lower edge", r_M - r_0, [0.0, -h_M, 0.0], [1.0, r_M, 0.0]),
    ]
    sim = sweep.Simulation.from_equations([toy], contacts, q0=q_start, v0=v_start, dt=h,
                                          t_end=t_end, scheme=scheme)
    times, heights, pecks, beak_was_closed = [], [], [], True
    for _ in range(int(round(t_end / h))):
        sim.step()
        times.append(sim.t)
        heights.append(sim.q[0])
        beak_closed = sim.constraint_impulses()[0, 0] > 0.0
        if beak_closed and not beak_was_closed:
            pecks.append(sim.t)
        beak_was_closed = beak_closed
    return np.array(times), np.array(heights), np.array(pecks)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "woodpecker.png"
    t_end = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    figure, ax = plt.subplots(figsize=(7, 4))
    for scheme in ("moreau-jean", "catching-up"):
        t, y, pecks = woodpecker(scheme, t_end)
        period = np.diff(pecks).mean() if len(pecks) > 1 else float("nan")
        descent = (y[0] - y[-1]) / (t[-1] - t[0])
        print(f"{scheme}: {len(pecks)} pecks, period {period:.4f} s, "
              f"descent {descent:.4f} m/s")
        ax.plot(t, y, label=scheme)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("sleeve height y (m)")
    ax.legend()
    figure.tight_layout()
    figure.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
