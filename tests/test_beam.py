"""Timoshenko beam (geocel.bodies.beam) checked against closed-form beam theory.

Reference values come from textbook formulas (Timoshenko cantilever, bar wave speed, section properties,
closed-form eigenfrequencies of a free element with lumped mass), never from the code's own output.
Conventions: z up, beam on the z axis, DOF order (u_x, u_y, u_z, θ_x, θ_y, θ_z), tension positive.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh

from geocel.bodies.beam import BeamSection, TimoshenkoBeam

E_STEEL = 210.0e9
NU_STEEL = 0.3
RHO_STEEL = 7850.0
G_STEEL = E_STEEL / (2.0 * (1.0 + NU_STEEL))
C_BAR = np.sqrt(E_STEEL / RHO_STEEL)


def slender_pile() -> tuple[TimoshenkoBeam, float]:
    """Steel tube pile D 0.6 m, t 20 mm, L 10 m, 10 elements."""
    sec = BeamSection.tube(0.6, 0.02, E_STEEL, NU_STEEL, RHO_STEEL)
    return TimoshenkoBeam(np.linspace(0.0, 10.0, 11), sec), 10.0


def stocky_beam() -> tuple[TimoshenkoBeam, float]:
    """Solid steel circle D 0.6 m, L = 2D = 1.2 m, 8 elements."""
    sec = BeamSection.solid_circle(0.6, E_STEEL, NU_STEEL, RHO_STEEL)
    return TimoshenkoBeam(np.linspace(0.0, 1.2, 9), sec), 1.2


CASES = {"slender": slender_pile, "stocky": stocky_beam}

# tip load: P_x, P_y (N), axial tension N (N), torque T (N·m)
PX, PY, NAX, TQ = 2.0e5, -1.3e5, 3.0e6, 4.0e4


def rigid_field(z: np.ndarray, trans: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """u = t + θ × r for nodes at r = (0, 0, z), rotations θ at every node."""
    r = np.column_stack([np.zeros_like(z), np.zeros_like(z), z])
    u = np.zeros((z.size, 6))
    u[:, :3] = trans + np.cross(rot, r)
    u[:, 3:] = rot
    return u


def timoshenko_tip(sec: BeamSection, L: float, P: float, I: float, shear_area: float) -> float:
    """Cantilever tip deflection δ = PL³/(3EI) + PL/(κGA)."""
    return P * L**3 / (3.0 * sec.E * I) + P * L / (sec.G * shear_area)


def tip_load(beam: TimoshenkoBeam) -> np.ndarray:
    f = np.zeros((beam.n_nodes, 6))
    f[-1] = [PX, PY, NAX, 0.0, 0.0, TQ]
    return f


def check_cantilever(beam: TimoshenkoBeam, L: float, u: np.ndarray, rel: float) -> None:
    s = beam.section
    tip = u[-1]
    assert tip[0] == pytest.approx(timoshenko_tip(s, L, PX, s.Iy, s.shear_area_x), rel=rel)
    assert tip[1] == pytest.approx(timoshenko_tip(s, L, PY, s.Ix, s.shear_area_y), rel=rel)
    assert tip[2] == pytest.approx(NAX * L / (s.E * s.area), rel=rel)
    assert tip[5] == pytest.approx(TQ * L / (s.G * s.J), rel=rel)
    # tip rotations: bending only (shear adds none): θ_y = P_x L²/(2EI_y), θ_x = −P_y L²/(2EI_x)
    assert tip[4] == pytest.approx(PX * L**2 / (2.0 * s.E * s.Iy), rel=rel)
    assert tip[3] == pytest.approx(-PY * L**2 / (2.0 * s.E * s.Ix), rel=rel)


# ----------------------------------------------------------------------------------------------------------
# sections and validation
# ----------------------------------------------------------------------------------------------------------


def test_section_properties() -> None:
    D, t, nu = 0.6, 0.02, NU_STEEL
    s = BeamSection.solid_circle(D, E_STEEL, nu, RHO_STEEL)
    assert s.area == pytest.approx(np.pi * 0.09)
    assert s.Ix == pytest.approx(np.pi * 0.3**4 / 4.0) and s.Iy == s.Ix
    assert s.J == pytest.approx(np.pi * 0.3**4 / 2.0)
    assert s.shear_area_x / s.area == pytest.approx(6 * 1.3 / 8.8)
    assert s.G == pytest.approx(G_STEEL)
    tb = BeamSection.tube(D, t, E_STEEL, nu, RHO_STEEL)
    Rm = (D - t) / 2.0
    # thin-walled approximations A ≈ 2πR t, I ≈ π R³ t (R: mid-wall radius)
    assert tb.area == pytest.approx(2 * np.pi * Rm * t, rel=1e-12)
    assert tb.Ix == pytest.approx(np.pi * Rm**3 * t, rel=2e-3)
    assert tb.J == pytest.approx(2.0 * tb.Ix)
    assert tb.shear_area_y / tb.area == pytest.approx(2 * 1.3 / 4.9)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(E=-1.0),
        dict(nu=0.5),
        dict(nu=-1.0),
        dict(density=0.0),
        dict(area=np.nan),
        dict(Ix=0.0),
        dict(J=-1.0),
        dict(shear_area_x=2.0),
    ],
)
def test_section_validation(kwargs: dict) -> None:
    base = dict(
        E=1e9, nu=0.3, density=1000.0, area=1.0, Ix=0.1, Iy=0.1, J=0.2, shear_area_x=0.8, shear_area_y=0.8
    )
    base.update(kwargs)
    with pytest.raises(ValueError):
        BeamSection(**base)


def test_constructor_validation() -> None:
    s = BeamSection.solid_circle(0.5, E_STEEL, NU_STEEL, RHO_STEEL)
    for z in ([0.0], [0.0, 1.0, 0.5], [0.0, 0.0, 1.0], [[0.0, 1.0]], [0.0, np.inf]):
        with pytest.raises(ValueError):
            TimoshenkoBeam(np.array(z), s)
    with pytest.raises(ValueError):
        BeamSection.tube(0.6, 0.3, E_STEEL, NU_STEEL, RHO_STEEL)


def test_lumped_mass() -> None:
    beam, L = slender_pile()
    s = beam.section
    total = s.density * s.area * L
    np.testing.assert_allclose(beam.mass[:, :3].sum(axis=0), total, rtol=1e-12)
    np.testing.assert_allclose(beam.mass[:, 5].sum(), s.density * s.J * L, rtol=1e-12)
    # scaled rotary inertia never below the physical one; unscaled equals ρIL
    phys = TimoshenkoBeam(beam.z, s, rotary_scaling=False)
    np.testing.assert_allclose(phys.mass[:, 3].sum(), s.density * s.Ix * L, rtol=1e-12)
    assert np.all(beam.mass[:, 3:5] >= phys.mass[:, 3:5] * (1 - 1e-12))


# ----------------------------------------------------------------------------------------------------------
# kernel consistency, rigid-body modes, equilibrium
# ----------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("descending", [False, True])
def test_kernel_matches_matrix(descending: bool) -> None:
    rng = np.random.default_rng(1)
    z = np.cumsum(rng.uniform(0.3, 1.5, 7))
    z = z[::-1] if descending else z
    beam = TimoshenkoBeam(z, BeamSection.tube(0.6, 0.03, E_STEEL, NU_STEEL, RHO_STEEL))
    K = beam.assemble_stiffness()
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-9 * np.abs(K).max())
    for _ in range(3):
        u = rng.standard_normal((beam.n_nodes, 6)) * 1e-3
        f = beam.internal_forces(u)
        np.testing.assert_allclose(f.ravel(), K @ u.ravel(), rtol=0, atol=1e-12 * np.abs(f).max())
    # six zero eigenvalues (rigid-body modes), the rest positive
    lam = np.linalg.eigvalsh(K)
    assert np.sum(np.abs(lam) < 1e-9 * lam.max()) == 6
    assert np.all(lam > -1e-9 * lam.max())


def test_rigid_body_modes_give_no_force() -> None:
    beam, _ = slender_pile()
    s = beam.section
    scale = s.E * s.area / beam.length[0]  # force per unit displacement of one element
    rng = np.random.default_rng(2)
    fields = [
        rigid_field(beam.z, rng.standard_normal(3) * 1e-2, np.zeros(3)),  # translation
        rigid_field(beam.z, np.zeros(3), np.array([1e-3, 0.0, 0.0])),  # rotation about x
        rigid_field(beam.z, np.zeros(3), np.array([0.0, -2e-3, 0.0])),  # rotation about y
        rigid_field(beam.z, rng.standard_normal(3) * 1e-2, rng.standard_normal(3) * 1e-3),  # general
    ]
    for u in fields:
        f = beam.internal_forces(u)
        assert np.abs(f).max() < 1e-12 * scale * 1e-2
        assert np.abs(beam.axial_force(u)).max() < 1e-12 * scale * 1e-2
        assert np.abs(beam.bending_moment(u)).max() < 1e-12 * scale * 1e-2
        assert np.abs(beam.shear_force(u)).max() < 1e-12 * scale * 1e-2
    # a non-rigid field does produce forces (the check above is not vacuous)
    u = fields[1].copy()
    u[:, 3] = 0.0
    assert np.abs(beam.internal_forces(u)).max() > 1e-6 * scale


def test_element_equilibrium_random_u() -> None:
    rng = np.random.default_rng(3)
    sec = BeamSection.solid_circle(0.8, E_STEEL, NU_STEEL, RHO_STEEL)
    beam = TimoshenkoBeam(np.array([2.0, 2.7]), sec)
    p = np.array([0.4, -1.1, 5.0])  # reference point for moments
    r = np.column_stack([np.zeros(2), np.zeros(2), beam.z]) - p
    for _ in range(5):
        f = beam.internal_forces(rng.standard_normal((2, 6)) * 1e-3)
        scale = np.abs(f).max()
        force = f[:, :3].sum(axis=0)
        moment = (np.cross(r, f[:, :3]) + f[:, 3:]).sum(axis=0)
        assert np.abs(force).max() < 1e-12 * scale
        assert np.abs(moment).max() < 1e-11 * scale


# ----------------------------------------------------------------------------------------------------------
# cantilever: static and dynamic relaxation
# ----------------------------------------------------------------------------------------------------------


def static_solve(beam: TimoshenkoBeam, f: np.ndarray) -> np.ndarray:
    K = beam.assemble_stiffness()
    free = np.arange(6, 6 * beam.n_nodes)  # base node (node 0, z = 0) clamped
    u = np.zeros(6 * beam.n_nodes)
    u[free] = np.linalg.solve(K[np.ix_(free, free)], f.ravel()[free])
    return u.reshape(-1, 6)


@pytest.mark.parametrize("case", CASES)
def test_cantilever_static(case: str) -> None:
    beam, L = CASES[case]()
    s = beam.section
    # the shear term is significant (> 1/2 % slender, > 5 % stocky), so the 1 % check tests it
    eb = PX * L**3 / (3 * s.E * s.Iy)
    assert timoshenko_tip(s, L, PX, s.Iy, s.shear_area_x) / eb - 1.0 > (0.005 if case == "slender" else 0.05)
    u = static_solve(beam, tip_load(beam))
    check_cantilever(beam, L, u, rel=0.01)
    # stress resultants at the element midpoints (exact element: to round-off)
    arm = L - beam.z_mid
    np.testing.assert_allclose(beam.axial_force(u), NAX, rtol=1e-9)
    np.testing.assert_allclose(beam.torque(u), TQ, rtol=1e-9)
    M = beam.bending_moment(u)
    np.testing.assert_allclose(M[:, 1], PX * arm, rtol=1e-7)
    np.testing.assert_allclose(M[:, 0], -PY * arm, rtol=1e-7)
    V = beam.shear_force(u)
    np.testing.assert_allclose(V[:, 0], PX, rtol=1e-7)
    np.testing.assert_allclose(V[:, 1], PY, rtol=1e-7)


@pytest.mark.parametrize("case", CASES)
def test_cantilever_dynamic_relaxation(case: str) -> None:
    beam, L = CASES[case]()
    fixed = np.zeros((beam.n_nodes, 6), dtype=bool)
    fixed[0] = True
    # fundamental frequency of the clamped beam (generalized eigenproblem) → critical damping c = 2ω₁
    free = np.arange(6, 6 * beam.n_nodes)
    K = beam.assemble_stiffness()[np.ix_(free, free)]
    w1 = np.sqrt(eigh(K, np.diag(beam.mass.ravel()[free]), eigvals_only=True, subset_by_index=[0, 0])[0])
    dt = 0.9 * beam.stable_time_step()[0]
    f = tip_load(beam)
    n_steps = int(np.ceil(25.0 / (w1 * dt)))
    assert n_steps < 20000
    for _ in range(n_steps):
        f_int = beam.step(dt, f, fixed, damping=2.0 * w1)
    check_cantilever(beam, L, beam.u, rel=0.01)
    residual = (f - f_int)[1:]
    assert np.abs(residual).max() < 1e-4 * PX
    assert beam.kinetic_energy() < 1e-8 * beam.strain_energy()


# ----------------------------------------------------------------------------------------------------------
# explicit dynamics: wave speed and stable time step
# ----------------------------------------------------------------------------------------------------------


def test_axial_wave_speed() -> None:
    n_el, h = 200, 1.0
    beam = TimoshenkoBeam(
        np.arange(n_el + 1) * h, BeamSection.solid_circle(0.1, E_STEEL, NU_STEEL, RHO_STEEL)
    )
    s = beam.section
    dt = 0.9 * beam.stable_time_step()[0]
    F = 1.0e4  # step force at the base → velocity step v₀ = F/(ρAc)
    v0 = F / (s.density * s.area * C_BAR)
    f = np.zeros((beam.n_nodes, 6))
    f[0, 2] = F
    stations = (40, 160)
    hist = []
    n_steps = int(np.ceil((stations[1] + 20) * h / C_BAR / dt))
    for _ in range(n_steps):
        beam.step(dt, f)
        hist.append(beam.v[list(stations), 2].copy())
    hist = np.array(hist)
    t = (np.arange(n_steps) + 0.5) * dt  # velocities live at half steps
    arrivals = []
    for k in range(2):
        i = int(np.argmax(hist[:, k] > 0.5 * v0))
        assert i > 0
        y0, y1 = hist[i - 1, k], hist[i, k]
        arrivals.append(t[i - 1] + (0.5 * v0 - y0) / (y1 - y0) * dt)
    c_meas = (stations[1] - stations[0]) * h / (arrivals[1] - arrivals[0])
    assert c_meas == pytest.approx(C_BAR, rel=0.02)
    # behind the front the particle velocity is F/(ρAc) (impedance check)
    assert np.mean(hist[-30:, 0]) == pytest.approx(v0, rel=0.05)


def closed_form_dt(sec: BeamSection, L: float, scaled: bool) -> float:
    """2/ω_max of one free element with lumped mass: the modes decouple into axial (ω² = 4E/(ρL²)),
    torsion (4G/(ρL²)) and, per bending plane, the symmetric bending mode ψ₁ = −ψ₂ (ω² = 2EI/(L j)) and the
    shear–rotation mode w₁ = −w₂, ψ₁ = ψ₂ (ω² = k_s (2/(mL) + L/(2j)), k_s = 12EI/((1+Φ)L²)), with
    m = ρAL/2 and j the lumped rotary inertia."""
    rho, E, G = sec.density, sec.E, sec.G
    m = rho * sec.area * L / 2.0
    w2 = [4.0 * E / (rho * L**2), 4.0 * G / (rho * L**2)]
    for I, As in ((sec.Iy, sec.shear_area_x), (sec.Ix, sec.shear_area_y)):
        j = rho * I * L / 2.0
        if scaled:
            j = max(j, rho * sec.area * L**3 / 48.0)
        phi = 12.0 * E * I / (G * As * L**2)
        ks = 12.0 * E * I / ((1.0 + phi) * L**2)
        w2 += [2.0 * E * I / (L * j), ks * (2.0 / (m * L) + L / (2.0 * j))]
    return 2.0 / np.sqrt(max(w2))


@pytest.mark.parametrize("scaled", [True, False])
@pytest.mark.parametrize("diameter", [0.1, 0.6, 2.0])
def test_stable_time_step_closed_form(scaled: bool, diameter: float) -> None:
    L = 1.0
    sec = BeamSection.solid_circle(diameter, E_STEEL, NU_STEEL, RHO_STEEL)
    beam = TimoshenkoBeam(np.array([0.0, L]), sec, rotary_scaling=scaled)
    dt, e = beam.stable_time_step()
    assert e == 0
    assert dt == pytest.approx(closed_form_dt(sec, L, scaled), rel=1e-9)
    if diameter == 0.1:
        if scaled:
            # slender element with scaled rotary inertia: the axial mode governs, Δt = L/c exactly
            # (lumped mass; the consistent-mass bar would give L/(√3 c))
            assert dt == pytest.approx(L / C_BAR, rel=1e-9)
        else:
            # physical rotary inertia: the shear–rotation mode governs, Δt ≈ L/(√3 c)
            assert dt == pytest.approx(L / (np.sqrt(3.0) * C_BAR), rel=0.02)


def test_element_bound_is_safe_and_reports_element() -> None:
    z = np.concatenate([np.linspace(0.0, 8.0, 9), [8.5, 8.8]])  # shortest element last
    beam = TimoshenkoBeam(z, BeamSection.tube(0.6, 0.02, E_STEEL, NU_STEEL, RHO_STEEL))
    dt, e = beam.stable_time_step()
    assert e == beam.n_elements - 1
    w_max = np.sqrt(eigh(beam.assemble_stiffness(), np.diag(beam.mass.ravel()), eigvals_only=True)[-1])
    assert dt <= 2.0 / w_max * (1 + 1e-9)
    assert dt > 0.5 * 2.0 / w_max  # and not needlessly small


@pytest.mark.parametrize("factor, unstable", [(1.01, True), (0.99, False)])
def test_explicit_stability_limit(factor: float, unstable: bool) -> None:
    for scaled in (True, False):
        beam = TimoshenkoBeam(
            np.array([0.0, 1.0]),
            BeamSection.tube(0.6, 0.02, E_STEEL, NU_STEEL, RHO_STEEL),
            rotary_scaling=scaled,
        )
        dt = factor * beam.stable_time_step()[0]
        beam.u[:] = np.random.default_rng(4).standard_normal((2, 6)) * 1e-3
        amp0 = np.abs(beam.u).max()
        amps = []
        for _ in range(400):
            beam.step(dt)
            amps.append(np.abs(beam.u).max())
        amps = np.array(amps)
        if unstable:
            assert not np.all(np.isfinite(amps)) or amps.max() > 1e6 * amp0
        else:
            assert np.all(np.isfinite(amps))
            assert amps.max() < 100.0 * amp0
            assert amps[-100:].max() < 1.5 * amps[:100].max()
