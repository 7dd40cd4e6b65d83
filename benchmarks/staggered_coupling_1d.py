"""The staggered soil–pile coupling of geocel in one dimension: when does it oscillate?

A steel pile (elastic bar, subcycled within the soil step, the contact load of the last soil step held over
the substeps) pushes an elastic–perfectly-plastic soil bar through the same one-sided velocity projection as
:mod:`geocel.contact.kernels`: the soil's top node takes the pile base's velocity when it approaches it, and
the impulse acts on the pile in the next soil step. The reference is a rigid pile (prescribed velocity).

Printed per case: mean and standard deviation of the base force per soil step (as q_b, MPa) in the second
half of the run, and the share of soil steps without contact. The soil node mass is varied by
``--soil-mass`` (a factor on ρ A h: in 3D, the soil in contact grows with the embedded shaft), for the three
couplings: the pile velocity at the last substep with the held load (``end``), the mean velocity over the
soil step (``mean``), the mean velocity with the mean of the last two loads (``mean+avg``: tried in geocel
and reverted, in 3D it moved the oscillation to a three-step period), and the mean velocity with the
interface damper (``damper``, geocel's solid pile: the held load plus the soil's linearised answer
−(m/Δt)(v − v_seen) to the base velocity, implicit in the substeps), and the damper with the held load less
the tied soil's inertia of the last step, m (v_seen − v_seen_prev)/Δt (``damper+ff``, geocel's before
2026-12-07: in 3D it pumped the pile's axial modes at S = 10; here it fails at large mass ratios).

Run: ``python benchmarks/staggered_coupling_1d.py`` (about 10 s)."""

from __future__ import annotations

import argparse

import numpy as np

AREA = 0.0707  # m², a quarter of the D = 0.6 m pile
V0 = 0.5  # jacking velocity, m/s


def run(
    rigid: bool,
    soil_mass: float,
    mean_velocity: bool,
    average_load: bool,
    damper: bool = False,
    duration: float = 0.6,
    feed_forward: bool = False,
):
    """Base force per soil step (N) of one run; see the module docstring."""
    n_p, h_p, e_p, rho_p = 50, 0.2, 210e9, 7850.0  # pile: 10 m of steel
    n_s, h_s, e_s, rho_s, q_y = 60, 0.2, 300e6, 2000.0, 8e6  # soil: 12 m, yields at 8 MPa
    m_p = np.full(n_p + 1, rho_p * AREA * h_p)
    m_p[[0, -1]] *= 0.5
    m_s = np.full(n_s + 1, rho_s * AREA * h_s * soil_mass)
    m_s[0] *= 0.5
    dt = 0.9 * h_s / np.sqrt(e_s / rho_s)
    n_sub = int(np.ceil(dt / (0.9 * h_p / np.sqrt(e_p / rho_p))))
    h = dt / n_sub
    u_p = np.zeros(n_p + 1)  # pile, positive down; node 0 = head, -1 = base
    v_p = np.full(n_p + 1, V0)
    u_s = np.zeros(n_s + 1)  # soil, positive down; node 0 = surface under the base
    v_s = np.zeros(n_s + 1)
    eps_p = np.zeros(n_s)
    load = load_prev = 0.0
    m_a = 0.0  # soil mass tied to the base in the last projection
    v_seen = v_seen_prev = V0  # base velocity of the last two projections
    t, out = 0.0, []
    while t < duration:
        if rigid:
            v_base = V0
        else:
            f_base = 0.5 * (load + load_prev) if average_load else load
            c_a = 0.0
            if damper:  # the tied soil's linearised answer to the base's velocity: a dashpot m/Δt
                c_a = m_a / dt
                if feed_forward:  # (the held load less the tied soil's inertia of the last step)
                    f_base -= m_a * (v_seen - v_seen_prev) / dt
            u0 = u_p[-1]
            for _ in range(n_sub):
                axial = -e_p * AREA * np.diff(u_p) / h_p  # compression positive
                f = np.zeros(n_p + 1)
                f[:-1] -= axial
                f[1:] += axial
                f[-1] -= f_base - c_a * v_seen
                v_p[:-1] += h * f[:-1] / m_p[:-1]
                v_p[-1] = (v_p[-1] + h * f[-1] / m_p[-1]) / (1.0 + h * c_a / m_p[-1])  # dashpot implicit
                v_p[0] = V0
                u_p += h * v_p
            v_base = (u_p[-1] - u0) / dt if mean_velocity else v_p[-1]
            v_seen_prev, v_seen = v_seen, v_base
        # soil: elastic–perfectly plastic in compression, no tension
        trial = -e_s * (np.diff(u_s) / h_s - eps_p)
        excess = np.maximum(trial - q_y, 0.0)
        eps_p -= excess / e_s
        sig = np.maximum(trial - excess, 0.0)
        f = np.zeros(n_s + 1)
        f[:-1] -= sig * AREA
        f[1:] += sig * AREA
        v_s += dt * f / m_s
        v_s[-1] = 0.0
        # contact: one-sided projection of the surface node onto the pile base
        load_prev, load, m_a = load, 0.0, 0.0
        if v_s[0] < v_base:
            load = m_s[0] * (v_base - v_s[0]) / dt
            v_s[0] = v_base
            m_a = m_s[0]
        u_s += dt * v_s
        t += dt
        out.append(load)
    return np.array(out), m_s[0], m_p[-1], n_sub


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--soil-mass", type=float, nargs="+", default=[1.0, 16.0, 256.0, 1024.0])
    args = ap.parse_args()
    for factor in args.soil_mass:
        ref, ms, mp, n_sub = run(True, factor, False, False)
        half = len(ref) // 2
        print(
            f"soil node {ms:.0f} kg against pile base node {mp:.0f} kg ({n_sub} substeps); "
            f"rigid pile: q_b {ref[half:].mean() / AREA / 1e6:.2f} ± {ref[half:].std() / AREA / 1e6:.2f} MPa"
        )
        for name, mean_v, avg, damp, ff in (
            ("end", False, False, False, False),
            ("mean", True, False, False, False),
            ("mean+avg", True, True, False, False),
            ("damper", True, False, True, False),
            ("damper+ff", True, False, True, True),
        ):
            f, *_ = run(False, factor, mean_v, avg, damp, feed_forward=ff)
            f = f[half:]
            q = f / AREA / 1e6
            if not np.all(np.isfinite(q)) or np.abs(q).max() > 1e3:
                print(f"  {name:9s} diverged (|q_b| up to {np.nanmax(np.abs(q)):.1e} MPa)")
                continue
            print(f"  {name:9s} q_b {q.mean():6.2f} ± {q.std():6.2f} MPa, steps without contact {np.mean(f == 0.0):.0%}")


if __name__ == "__main__":
    main()
