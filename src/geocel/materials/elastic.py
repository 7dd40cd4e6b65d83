"""Isotropic linear (hypo)elastic soil: σ̊ = λ tr(D) I + 2μ D with Jaumann co-rotation.

Parameter array: ``[E (Pa), ν]``. State: ``state[0] = e`` (void ratio, kinematic update).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import flags as fl
from .tensor import co_rotate, is_zero

P_E = 0
P_NU = 1
N_PARAMS = 2
N_STATE = 1
STATE_NAMES = ("e",)


@njit(cache=True, inline="always")
def lame(prm):
    """Lamé constants (λ, μ) from E and ν."""
    E = prm[0]
    nu = prm[1]
    mu = E / (2.0 * (1.0 + nu))
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    return lam, mu


@njit(cache=True, inline="always")
def update_void_ratio(state, deps):
    """e ← (1 + e) J_{n+1}/J_n − 1 with J_{n+1}/J_n = exp(tr Δε) (logarithmic volumetric strain)."""
    state[0] = (1.0 + state[0]) * np.exp(deps[0] + deps[1] + deps[2]) - 1.0


@njit(cache=True)
def elastic_update(prm, stress, state, deps, dspin, tol, nsub):
    """Exact update; returns (P-wave modulus λ + 2μ, flags)."""
    co_rotate(stress, dspin)
    lam, mu = lame(prm)
    tr = deps[0] + deps[1] + deps[2]
    if is_zero(deps):
        return lam + 2.0 * mu, fl.ZERO_INCREMENT
    for i in range(3):
        stress[i] += lam * tr + 2.0 * mu * deps[i]
    for i in range(3, 6):
        stress[i] += 2.0 * mu * deps[i]
    update_void_ratio(state, deps)
    return lam + 2.0 * mu, 0
