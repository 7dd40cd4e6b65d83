"""Remap of the axisymmetric (r–z) soil back onto the fixed grid (issue 17).

Directional splitting in r and z (the order alternates from one remap to the next), conservative with the
per-radian volumes V = r_c h_r h_z: a radial face at r_f has the area r_f h_z, an axial face r_c h_r.

* **Lagrangian volume change** (:func:`volume_change_rz`): J = 1 + Δt [(r₁ū₁ − r₀ū₀)/(r_c h_r) +
  (w̄₁ − w̄₀)/h_z] with ū, w̄ the mean normal velocities of the faces. This is exactly the one-point
  divergence ∂v_r/∂r + v̄_r/r_c + ∂v_z/∂z of the Lagrangian step (r₁ = r_c + h_r/2, r₀ = r_c − h_r/2), and
  the two sweeps return every cell to its volume V exactly.
* **The sweeps are those of the 3D remap** (:func:`geocel.euler.remap.sweep_cells`,
  :func:`~geocel.euler.remap.sweep_nodes`: Hirt–Nichols donor–acceptor soil volume, van Leer mass, stress
  and state per soil volume, nodal momentum on the dual grid), run on a wedge one cell thick in θ whose
  geometry enters only through the face areas: the r sweep gets the face velocity u r_f (the area r_f h_z
  as u_f r_f × h_z), the z sweep the area r_c h_r. The wedge's two node copies (θ = 0 and θ = 1 rad)
  would each hold half the nodal mass and the same velocity, so the node sweep advects one of them (with
  its in-plane components only) and the dual-grid fluxes give every node exactly Σ m_cell/4 again.

Mass is conserved to round-off (the top face of the domain is open: material leaving is counted).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..materials.tensor import KERNEL_OPTIONS
from .axisym import NO_SPLIT
from .remap import drain, faces_of, split_sweeps


@njit(parallel=True, **KERNEL_OPTIONS)
def volume_change_rz(r, hr, hz, u, dt, Vs, Vcur, split=NO_SPLIT):
    """V_cur = V J and V_s ← V_s J for every cell, J = 1 + Δt ∇·u with the face-flux divergence above.
    ``split``: a node (i_s, k_s) split at the pile's corner (:func:`geocel.euler.axisym.split_gradient_rz`): the
    cells left of it see the vertical motion ``split[2]``, the cell right of and above it the radial motion
    ``split[3]`` (m with the accumulated motion)."""
    ncr, ncz = Vs.shape
    si = int(split[0])
    sk = int(split[1])
    for i in prange(ncr):
        rc = 0.5 * (r[i] + r[i + 1])
        for k in range(ncz):
            vol = rc * hr[i] * hz[k]
            u1 = 0.5 * (u[i + 1, k, 0] + u[i + 1, k + 1, 0])
            u0 = 0.5 * (u[i, k, 0] + u[i, k + 1, 0])
            w1 = 0.5 * (u[i, k + 1, 1] + u[i + 1, k + 1, 1])
            w0 = 0.5 * (u[i, k, 1] + u[i + 1, k, 1])
            if i == si - 1 and k == sk - 1:
                w1 = 0.5 * (u[i, k + 1, 1] + split[2])
            elif i == si - 1 and k == sk:
                w0 = 0.5 * (u[i, k, 1] + split[2])
            elif i == si and k == sk:
                u0 = 0.5 * (split[3] + u[i, k + 1, 0])
            J = 1.0 + dt * ((r[i + 1] * u1 - r[i] * u0) / (rc * hr[i]) + (w1 - w0) / hz[k])
            Vcur[i, k] = vol * J
            Vs[i, k] *= J


@njit(**KERNEL_OPTIONS)
def _to_wedge(r, u, v, nmass, u3, v3, m_cur):
    """The wedge's node copies: mesh motion (u_r r, 0, u_z) at both; velocity (v_r, v_z) and half the nodal
    mass at one (the copies are equal, so the node sweep advects one)."""
    nr1, nz1 = nmass.shape
    for i in range(nr1):
        for c in range(2):
            for k in range(nz1):
                u3[i, c, k, 0] = u[i, k, 0] * r[i]
                u3[i, c, k, 2] = u[i, k, 1]
        for k in range(nz1):
            v3[i, 0, k, 0] = v[i, k, 0]
            v3[i, 0, k, 1] = v[i, k, 1]
            m_cur[i, 0, k] = 0.5 * nmass[i, k]


@njit(**KERNEL_OPTIONS)
def _from_wedge(m_cur, v3, nmass, v):
    nr1, nz1 = nmass.shape
    for i in range(nr1):
        for k in range(nz1):
            nmass[i, k] = 2.0 * m_cur[i, 0, k]
            v[i, k, 0] = v3[i, 0, k, 0]
            v[i, k, 1] = v3[i, 0, k, 1]


_ORDERS = ((0, 2), (2, 0))
# the wedge's arrays are (r, θ, z); the swept axis comes last, as in the 3D remap, and the other in-plane axis
# first: the sweep kernels run their parallel loop over the first axis (θ, one cell, would leave it serial)
_PERM = {0: (2, 1, 0), 2: (0, 1, 2)}


def remap_rz(
    r: np.ndarray, hz: np.ndarray, active: np.ndarray, v: np.ndarray, dt: float, Vs: np.ndarray, Vcur: np.ndarray,
    mass: np.ndarray, stress: np.ndarray, state: np.ndarray, nmass: np.ndarray, fbar: np.ndarray, parity: int,
    mtiny: float, rho_lo: float = 0.0, rho_hi: float = np.inf, displacement: np.ndarray | None = None,
    work: dict | None = None, split: np.ndarray = NO_SPLIT,
) -> tuple[float, float]:  # fmt: skip
    """Advect everything back to the fixed r–z grid (in place): node radii ``r`` (nr+1), cell heights ``hz``
    (nz), cell arrays (nr, nz[, k]), node arrays (nr+1, nz+1[, 2]) with velocity components (v_r, v_z).
    ``nmass`` (per radian) holds the nodal masses on entry and is updated; ``state`` the advected state
    components. The mesh motion is v Δt, or ``displacement`` (m, accumulated over several steps; ``dt`` is
    then ignored). ``active`` (nr, nz) bool: faces next to an inactive cell carry no flux. ``fbar`` (nr, nz)
    is scratch, and so is ``work`` (a dict the caller keeps between calls, for the wedge's buffers); ``split``: a
    node split at the pile's corner (:func:`volume_change_rz`). Returns
    (mass lost through the top, soil volume capped)."""
    if displacement is None:
        u, dt = v, dt
    else:
        u, dt = displacement, 1.0
    hr = np.diff(r)
    rc = 0.5 * (r[1:] + r[:-1])
    volume_change_rz(r, hr, hz, u, dt, Vs, Vcur, split)
    nr1, nz1 = nmass.shape
    if work is None:
        work = {}
    if work.get("shape") != (nr1, nz1):  # the wedge's buffers, kept by the caller between remaps
        work.update(
            shape=(nr1, nz1),
            u3=np.zeros((nr1, 2, nz1, 3)),
            v3=np.zeros((nr1, 1, nz1, 2)),
            m_cur=np.empty((nr1, 1, nz1)),
            m_next=np.empty((nr1, 1, nz1)),
            phi=np.empty((Vs.shape[0], 1, Vs.shape[1])),
        )
    u3, v3, m_cur, m_next, phi = work["u3"], work["v3"], work["m_cur"], work["m_next"], work["phi"]
    _to_wedge(r, u, v, nmass, u3, v3, m_cur)
    # face areas: the r sweep's transverse sizes (z, θ) = (h_z, 1), the z sweep's (r, θ) = (r_c h_r, 1)
    h = (rc * hr, np.ones(1), np.ascontiguousarray(hz))
    Vs3 = Vs[:, None, :]
    Vcur3 = Vcur[:, None, :]
    act3 = active[:, None, :]
    mass3 = mass[:, None, :]
    stress3 = stress[:, None, :, :]
    state3 = state[:, None, :, :]
    fbar3 = fbar[:, None, :]
    lost, capped, m_cur, _ = drain(
        split_sweeps(_ORDERS[parity % 2], _PERM, faces_of(h, _PERM), act3, u3, dt, phi, Vs3, Vcur3, mass3, stress3,
                     state3, fbar3, rho_lo, rho_hi, m_cur, m_next, v3, mtiny)
    )  # fmt: skip
    _from_wedge(m_cur, v3, nmass, v)
    return lost, capped
