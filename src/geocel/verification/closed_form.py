"""Closed-form solutions the checks compare against (SI units, compression negative as in the solver).

* Shield (1955): the smooth rigid circular punch on a Tresca half-space, q = 5.69 c_u;
* Lamé: the elastic thick cylinder a ≤ r ≤ b in plane strain under an inner pressure p;
* Hill (1950): the same cylinder in Tresca soil (c_u = k) with a plastic zone to c;
* the frictional cylinder in cohesionless Mohr–Coulomb soil (statically determinate with σ_zz intermediate);
* hypoplasticity (von Wolffersdorff 1996, Bauer 1996): the critical void ratio e_c(p) and the undrained steady
  state p_cs(e), the critical stress ratio M_c of the Matsuoka–Nakai cone.
"""

from __future__ import annotations

import math

import numpy as np

#: Shield (1955): limit pressure of a smooth rigid circular punch on a Tresca half-space, q/c_u
SHIELD_SMOOTH = 5.69


def lame(r: np.ndarray, p: float, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """σ_rr, σ_θθ (Pa) of an elastic cylinder a ≤ r ≤ b under the inner pressure p (Pa), the outer face free."""
    A = p * a * a / (b * b - a * a)
    return A * (1 - b * b / r**2), A * (1 + b * b / r**2)


def lame_inner_displacement(p: float, a: float, b: float, youngs_modulus: float, poisson_ratio: float) -> float:
    """u_r(a) (m) of the Lamé cylinder in plane strain."""
    A = p * a * a / (b * b - a * a)
    return (1 + poisson_ratio) / youngs_modulus * A * ((1 - 2 * poisson_ratio) * a + b * b / a)


def hill_pressure(k: float, a: float, b: float, c: float) -> float:
    """Inner pressure (Pa) at which the plastic zone of a Tresca cylinder (strength k) reaches the radius c."""
    return k * (1 - c * c / (b * b)) + 2 * k * math.log(c / a)


def hill(r: np.ndarray, k: float, b: float, c: float) -> tuple[np.ndarray, np.ndarray]:
    """σ_rr, σ_θθ (Pa) of Hill's cylinder with its plastic zone to c (plane strain, σ_zz intermediate)."""
    plastic = r < c
    inside = -k * (1 - c * c / (b * b)) - 2 * k * np.log(c / r)
    outside = -k * c * c / (b * b) * (b * b / r**2 - 1)
    s_rr = np.where(plastic, inside, outside)
    s_tt = np.where(plastic, s_rr + 2 * k, k * c * c / (b * b) * (b * b / r**2 + 1))
    return s_rr, s_tt


def critical_stress_ratio(phi_c_deg: float) -> float:
    """q/p at the critical state in triaxial compression, M_c = 6 sin φ_c/(3 − sin φ_c)."""
    s = math.sin(math.radians(phi_c_deg))
    return 6 * s / (3 - s)


def critical_void_ratio(p: float, e_c0: float, hs: float, n: float) -> float:
    """Bauer's critical void ratio e_c = e_c0 exp(−(3p/h_s)^n) at the mean stress p (Pa)."""
    return e_c0 * math.exp(-((3 * p / hs) ** n))


def steady_state_pressure(e: float, e_c0: float, hs: float, n: float) -> float:
    """The mean stress p_cs (Pa) at which the void ratio e is critical (the undrained steady state)."""
    return hs / 3 * math.log(e_c0 / e) ** (1 / n)
