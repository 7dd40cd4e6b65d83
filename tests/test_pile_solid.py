"""Pile geometry, O-grid hexahedral mesh and the explicit linear-elastic solid body.

Every check compares with something independent of the code under test: closed forms (π R² L, π D L,
F L/(EA), √(E/ρ), √(M/ρ)), the divergence theorem, a stiffness matrix assembled here from Gauss-integrated
shape-function gradients, and invariances (patch test, rigid rotation, rigid translation).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from geocel.bodies.geometry import PileGeometry, pile_mesh
from geocel.bodies.solid import SolidBody, gradient_operator

# natural coordinates of the C3D8 nodes
XI = np.array(
    [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]],
    float,
)
G3 = 1.0 / math.sqrt(3.0)
GAUSS = [np.array([a, b, c]) for a in (-G3, G3) for b in (-G3, G3) for c in (-G3, G3)]


# ------------------------------------------------------------------------------------------------ helpers
def shape_derivatives(p: np.ndarray) -> np.ndarray:
    """dN_I/dξ_k (8, 3) of the trilinear hexahedron at natural point p."""
    f = 1.0 + XI * p
    dn = np.empty((8, 3))
    dn[:, 0] = XI[:, 0] * f[:, 1] * f[:, 2] / 8.0
    dn[:, 1] = XI[:, 1] * f[:, 0] * f[:, 2] / 8.0
    dn[:, 2] = XI[:, 2] * f[:, 0] * f[:, 1] / 8.0
    return dn


def corner_jacobians(nodes: np.ndarray, hexes: np.ndarray) -> np.ndarray:
    """det J at the 8 corners of every element (m, 8)."""
    xe = nodes[hexes]
    out = np.empty((hexes.shape[0], 8))
    for I in range(8):
        jac = np.einsum("mJi,Jk->mik", xe, shape_derivatives(XI[I]))
        out[:, I] = np.linalg.det(jac)
    return out


def gauss_gradients(xe: np.ndarray) -> tuple[np.ndarray, float]:
    """∫∇N_I dV (8, 3) and V of one hexahedron by 2×2×2 Gauss quadrature (exact for trilinear elements)."""
    B = np.zeros((8, 3))
    V = 0.0
    for p in GAUSS:
        dn = shape_derivatives(p)
        jac = xe.T @ dn  # J_ik = ∂x_i/∂ξ_k
        dj = np.linalg.det(jac)
        B += dn @ np.linalg.inv(jac) * dj
        V += dj
    return B, V


def elastic_matrix(E: float, nu: float) -> np.ndarray:
    """6×6 isotropic stiffness in Voigt order (11, 22, 33, 12, 13, 23) with engineering shear."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    D = np.zeros((6, 6))
    D[:3, :3] = lam
    D[np.arange(3), np.arange(3)] += 2 * mu
    D[np.arange(3, 6), np.arange(3, 6)] = mu
    return D


def element_stiffness(xe: np.ndarray, E: float, nu: float) -> np.ndarray:
    """Uniform-strain stiffness (24×24) V B̄ᵀ D B̄ with the Gauss-integrated mean gradients."""
    B, V = gauss_gradients(xe)
    b = B / V
    Bv = np.zeros((6, 24))
    for I in range(8):
        bx, by, bz = b[I]
        Bv[0, 3 * I] = bx
        Bv[1, 3 * I + 1] = by
        Bv[2, 3 * I + 2] = bz
        Bv[3, 3 * I], Bv[3, 3 * I + 1] = by, bx
        Bv[4, 3 * I], Bv[4, 3 * I + 2] = bz, bx
        Bv[5, 3 * I + 1], Bv[5, 3 * I + 2] = bz, by
    return V * Bv.T @ elastic_matrix(E, nu) @ Bv


def box_mesh(nx, ny, nz, size=(1.0, 1.0, 1.0), distort=0.0, seed=0):
    """Structured C3D8 box mesh; interior nodes moved randomly by up to ``distort`` × cell size."""
    lx, ly, lz = size
    gx, gy, gz = np.meshgrid(
        np.linspace(0, lx, nx + 1), np.linspace(0, ly, ny + 1), np.linspace(0, lz, nz + 1), indexing="ij"
    )
    nodes = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)

    def nid(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    hexes = []
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                hexes.append(
                    [
                        nid(i, j, k),
                        nid(i + 1, j, k),
                        nid(i + 1, j + 1, k),
                        nid(i, j + 1, k),
                        nid(i, j, k + 1),
                        nid(i + 1, j, k + 1),
                        nid(i + 1, j + 1, k + 1),
                        nid(i, j + 1, k + 1),
                    ]
                )
    if distort > 0.0:
        rng = np.random.default_rng(seed)
        h = np.array([lx / nx, ly / ny, lz / nz])
        inner = (gx.ravel() > 0) & (gx.ravel() < lx) & (gy.ravel() > 0) & (gy.ravel() < ly)
        inner &= (gz.ravel() > 0) & (gz.ravel() < lz)
        nodes[inner] += rng.uniform(-distort, distort, (inner.sum(), 3)) * h
    return nodes, np.array(hexes, dtype=np.int64)


def face_normals_areas(nodes, faces):
    """Area-weighted normals ∫n dA (k, 3) and ∫x·n dA (k,) of bilinear quadrilaterals (2×2 Gauss, exact)."""
    p = nodes[faces]
    s_ = np.array([-1.0, 1.0, 1.0, -1.0])
    t_ = np.array([-1.0, -1.0, 1.0, 1.0])
    nA = np.zeros((faces.shape[0], 3))
    xn = np.zeros(faces.shape[0])
    for s in (-G3, G3):
        for t in (-G3, G3):
            N = (1 + s_ * s) * (1 + t_ * t) / 4.0
            ds = np.einsum("kIi,I->ki", p, s_ * (1 + t_ * t) / 4.0)
            dt = np.einsum("kIi,I->ki", p, t_ * (1 + s_ * s) / 4.0)
            n = np.cross(ds, dt)
            x = np.einsum("kIi,I->ki", p, N)
            nA += n
            xn += np.sum(x * n, axis=1)
    return nA, xn


def rotation(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def vec_to_mat(s):
    return np.array([[s[0], s[3], s[4]], [s[3], s[1], s[5]], [s[4], s[5], s[2]]])


def invariants(s):
    m = vec_to_mat(s)
    return np.array([np.trace(m), 0.5 * (np.trace(m) ** 2 - np.trace(m @ m)), np.linalg.det(m)])


# --------------------------------------------------------------------------------------------- geometry
def test_geometry_properties_and_validation():
    g = PileGeometry(diameter=0.6, length=11.0)
    assert g.radius == pytest.approx(0.3)
    assert g.base_area == pytest.approx(math.pi * 0.09)
    assert g.perimeter == pytest.approx(math.pi * 0.6)
    assert PileGeometry.embedded(0.6, 11.0, 2.0).z_tip == -2.0
    c = PileGeometry(0.6, 2.0, tip="conical", tip_angle=60.0)
    assert c.cone_height == pytest.approx(0.3 * math.sqrt(3.0))
    for bad in (
        dict(diameter=-0.6, length=1.0),
        dict(diameter=0.6, length=0.0),
        dict(diameter=0.6, length=1.0, tip="round"),
        dict(diameter=0.6, length=1.0, tip="conical", tip_angle=180.0),
        dict(diameter=0.6, length=0.4, tip="conical", tip_angle=60.0),  # cone (0.52 m) longer than pile
        dict(diameter=float("nan"), length=1.0),
    ):
        with pytest.raises(ValueError):
            PileGeometry(**bad)
    with pytest.raises(ValueError, match="symmetry"):
        pile_mesh(g, 0.1, symmetry="eighth")
    with pytest.raises(ValueError, match="element_size"):
        pile_mesh(g, -0.1)


@pytest.mark.parametrize("symmetry", ["quarter", "half", "full"])
def test_mesh_volume_jacobians_symmetry_and_surface(symmetry):
    D, L = 0.6, 2.0
    R = D / 2
    g = PileGeometry(D, L, z_tip=-0.5)
    mesh = pile_mesh(g, 0.1, symmetry)
    f = mesh.symmetry_factor
    assert f == {"quarter": 4, "half": 2, "full": 1}[symmetry]
    x, y, z = mesh.nodes.T

    # volume: the section is the polygon inscribed in the circle (N = 8 n_core ≥ 32 chords), whose area is
    # smaller than π R² by ≈ (2π/N)²/6 ≤ 0.65 %: hence below, and within 1 %
    err = mesh.volume() * f / (math.pi * R**2 * L) - 1.0
    assert -0.01 < err < 0.0

    # positive Jacobian at all 8 corners of every element
    assert corner_jacobians(mesh.nodes, mesh.hexes).min() > 0.0

    # extent and symmetry planes: nodes on them exactly, nothing beyond them
    assert np.all(np.hypot(x, y) <= R * (1 + 1e-12))
    tol = 1e-9 * R
    if symmetry == "quarter":
        assert x.min() == 0.0 and y.min() == 0.0
        near = (np.abs(x) < tol) | (np.abs(y) < tol)
        assert np.all((x[near] == 0.0) | (y[near] == 0.0))
        assert np.all(x[np.abs(x) < tol] == 0.0) and np.all(y[np.abs(y) < tol] == 0.0)
        assert np.count_nonzero(x == 0.0) == np.count_nonzero(y == 0.0) > 0
    elif symmetry == "half":
        assert y.min() == 0.0 and x.min() < -0.99 * R
        assert np.all(y[np.abs(y) < tol] == 0.0)
    else:
        assert x.min() < -0.99 * R and y.min() < -0.99 * R
    # no duplicate nodes
    assert np.unique(np.round(mesh.nodes, 9), axis=0).shape[0] == mesh.nodes.shape[0]

    # layers: all nodes of a level at exactly layer_z, equal counts, levels spaced ≈ element size
    assert mesh.layer_z[0] == g.z_tip and mesh.layer_z[-1] == pytest.approx(g.z_tip + L)
    assert np.all(z == mesh.layer_z[mesh.layer_of_node])
    counts = np.bincount(mesh.layer_of_node)
    assert np.all(counts == counts[0])
    assert np.allclose(np.diff(mesh.layer_z), 0.1)

    # surface faces: not on symmetry planes, outward, shaft area π D L / f within 1 % (chord perimeter)
    faces, kind = mesh.surface_faces, mesh.face_kind
    fx, fy = mesh.nodes[faces][..., 0], mesh.nodes[faces][..., 1]
    assert not np.any(np.all(fx == 0.0, axis=1) | np.all(fy == 0.0, axis=1))
    nA, _ = face_normals_areas(mesh.nodes, faces)
    centre = mesh.nodes[faces].mean(axis=1)
    radial = np.hstack([centre[:, :2], np.zeros((faces.shape[0], 1))])
    shaft = kind == 1
    assert np.all(np.sum(nA[shaft] * radial[shaft], axis=1) > 0.0)
    assert np.all(np.abs(nA[shaft, 2]) < 1e-12)
    assert np.all(nA[~shaft, 2] < 0.0)
    assert np.sum(np.linalg.norm(nA[shaft], axis=1)) * f / (math.pi * D * L) == pytest.approx(1.0, abs=0.01)
    assert mesh.face_areas()[shaft].sum() * f / (math.pi * D * L) == pytest.approx(1.0, abs=0.01)
    assert -nA[~shaft, 2].sum() * f / (math.pi * R**2) == pytest.approx(1.0, abs=0.01)

    if symmetry == "full":
        # closed surface (base + shaft + head): divergence theorem ∮ n dA = 0 and ⅓∮ x·n dA = V
        top = mesh.hexes[mesh.layer_of_node[mesh.hexes[:, 4]] == mesh.n_layers - 1][:, 4:]
        allf = np.vstack([faces, top])
        nA, xn = face_normals_areas(mesh.nodes, allf)
        assert np.abs(nA.sum(axis=0)).max() < 1e-12
        assert xn.sum() / 3.0 == pytest.approx(mesh.volume(), rel=1e-12)


@pytest.mark.parametrize("symmetry", ["quarter", "full"])
def test_conical_tip_mesh(symmetry):
    D, L = 0.6, 2.0
    R = D / 2
    g = PileGeometry(D, L, tip="conical", tip_angle=60.0, z_tip=-1.0)
    hc = g.cone_height
    mesh = pile_mesh(g, 0.1, symmetry)
    assert corner_jacobians(mesh.nodes, mesh.hexes).min() > 0.0
    exact = math.pi * R**2 * (L - hc) + math.pi * R**2 * hc / 3.0
    err = mesh.volume() * mesh.symmetry_factor / exact - 1.0
    assert -0.01 < err < 0.0
    x, y, z = mesh.nodes.T
    assert z.min() == pytest.approx(g.z_tip) and z.max() == pytest.approx(g.z_tip + L)
    # the base faces lie on the cone z − z_tip = h_c r / R, and face downward/outward
    base_nodes = np.unique(mesh.surface_faces[mesh.face_kind == 0])
    r = np.hypot(x[base_nodes], y[base_nodes])
    assert np.allclose(z[base_nodes] - g.z_tip, hc * r / R, atol=1e-12)
    nA, _ = face_normals_areas(mesh.nodes, mesh.surface_faces)
    assert np.all(nA[mesh.face_kind == 0, 2] < 0.0)
    # lateral cone area π R √(R² + h_c²) (polygonal: within 1 %)
    cone = nA[mesh.face_kind == 0]
    area = np.linalg.norm(cone, axis=1).sum() * mesh.symmetry_factor
    assert area / (math.pi * R * math.hypot(R, hc)) == pytest.approx(1.0, abs=0.01)
    # on the axis every level keeps its elevation; above the cone transition levels are flat again
    axis = (x == 0.0) & (y == 0.0)
    assert np.allclose(z[axis], mesh.layer_z[mesh.layer_of_node[axis]], atol=1e-12)
    high = mesh.layer_z[mesh.layer_of_node] > g.z_tip + 2 * hc + 1e-9
    assert np.all(z[high] == mesh.layer_z[mesh.layer_of_node[high]])


# ------------------------------------------------------------------------------------------- solid body
def test_gradient_operator_equals_gauss_integral():
    """Closed-form Flanagan–Belytschko B = Gauss-integrated ∫∇N dV on strongly distorted hexahedra."""
    rng = np.random.default_rng(3)
    B = np.empty((8, 3))
    for _ in range(20):
        xe = 0.5 * XI * rng.uniform(0.5, 2.0, 3) + rng.uniform(-0.2, 0.2, (8, 3))
        V = gradient_operator(xe, B)
        Bg, Vg = gauss_gradients(xe)
        assert V == pytest.approx(Vg, rel=1e-12)
        assert np.abs(B - Bg).max() < 1e-12 * np.abs(Bg).max()
        assert np.allclose(B.T @ xe, V * np.eye(3), atol=1e-12 * V)  # exact gradient of linear fields


def test_material_validation():
    nodes, hexes = box_mesh(1, 1, 1)
    for kw in (
        dict(youngs_modulus=-1.0, poisson_ratio=0.3, density=1.0),
        dict(youngs_modulus=1.0, poisson_ratio=0.5, density=1.0),
        dict(youngs_modulus=1.0, poisson_ratio=0.3, density=0.0),
        dict(youngs_modulus=1.0, poisson_ratio=0.3, density=1.0, hourglass=-0.1),
    ):
        with pytest.raises(ValueError):
            SolidBody(nodes, hexes, **kw)
    with pytest.raises(ValueError, match="volume"):
        SolidBody(nodes, hexes[:, [4, 5, 6, 7, 0, 1, 2, 3]], 1.0, 0.3, 1.0)  # inverted element


def test_patch_test_distorted_elements():
    """A homogeneous displacement gradient gives the same, exact strain and stress in every element and no
    resultant force on interior nodes (conical full mesh, every node moved at random)."""
    g = PileGeometry(0.6, 1.2, tip="conical")
    mesh = pile_mesh(g, 0.2, "full", n_core=2)
    rng = np.random.default_rng(7)
    nodes = mesh.nodes + rng.uniform(-0.012, 0.012, mesh.nodes.shape)
    assert corner_jacobians(nodes, mesh.hexes).min() > 0.0
    E, nu = 2.0e8, 0.27
    body = SolidBody(nodes, mesh.hexes, E, nu, 2000.0, bulk_viscosity=(0.0, 0.0))
    G = 1e-3 * rng.standard_normal((3, 3))
    dt = 1e-3
    body.step(dt, prescribed_velocity=(np.arange(body.n_nodes), nodes @ G.T / dt))
    assert np.allclose(body.x, nodes + nodes @ G.T, atol=1e-15)
    # strain increment on the mid-step configuration: sym(G (I + G/2)⁻¹)
    H = G @ np.linalg.inv(np.eye(3) + 0.5 * G)
    eps = 0.5 * (H + H.T)
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    sig = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
    expected = np.array([sig[0, 0], sig[1, 1], sig[2, 2], sig[0, 1], sig[0, 2], sig[1, 2]])
    scale = np.abs(expected).max()
    assert np.abs(body.stress - expected).max() < 1e-9 * scale
    # interior nodes: not on any surface face, not on the head level
    f = body.internal_forces()  # stress + hourglass (v is linear in x: no hourglass rate)
    boundary = np.zeros(body.n_nodes, bool)
    boundary[mesh.surface_faces.ravel()] = True
    boundary[mesh.layer_of_node == mesh.n_layers - 1] = True
    assert (~boundary).sum() > 10
    fscale = scale * 0.1**2
    assert np.abs(f[~boundary]).max() < 1e-9 * fscale
    assert np.abs(f[boundary]).max() > 1e-3 * fscale  # the check is not vacuous
    assert np.abs(f.sum(axis=0)).max() < 1e-9 * fscale  # global equilibrium


def _consistent_top_loads(nodes, quads, traction):
    """∫ N_I t dA on flat bilinear quadrilaterals (2×2 Gauss), nodal z-forces."""
    fz = np.zeros(nodes.shape[0])
    s_ = np.array([-1.0, 1.0, 1.0, -1.0])
    t_ = np.array([-1.0, -1.0, 1.0, 1.0])
    for quad in quads:
        p = nodes[quad, :2]
        for s in (-G3, G3):
            for t in (-G3, G3):
                N = (1 + s_ * s) * (1 + t_ * t) / 4
                J = np.array([p.T @ (s_ * (1 + t_ * t) / 4), p.T @ (t_ * (1 + s_ * s) / 4)])
                fz[quad] += traction * N * abs(np.linalg.det(J))
    return fz


def test_axial_stiffness_quarter_pile():
    """Quarter pile, symmetry planes on rollers, base on rollers (free to expand laterally), uniform pressure
    on the head: static shortening F L/(EA), lateral strain −ν × axial strain (uniaxial stress)."""
    D, L, E, nu, rho = 0.6, 1.0, 1.0e7, 0.3, 1000.0
    mesh = pile_mesh(PileGeometry(D, L), 0.1, "quarter")
    body = SolidBody.from_mesh(mesh, E, nu, rho)
    F = 1.0e3  # N on the whole pile (compressive); the quarter carries F/4
    top_quads = mesh.hexes[mesh.layer_of_node[mesh.hexes[:, 4]] == mesh.n_layers - 1][:, 4:]
    A_mesh = 4 * _consistent_top_loads(mesh.nodes, top_quads, 1.0).sum()
    f_ext = np.zeros((body.n_nodes, 3))
    f_ext[:, 2] = _consistent_top_loads(mesh.nodes, top_quads, -F / A_mesh)
    assert 4 * f_ext[:, 2].sum() == pytest.approx(-F)
    fixed = np.zeros((body.n_nodes, 3), bool)
    fixed[mesh.nodes[:, 0] == 0.0, 0] = True
    fixed[mesh.nodes[:, 1] == 0.0, 1] = True
    fixed[mesh.layer_of_node == 0, 2] = True
    # dynamic relaxation: mass-proportional damping, critical for the first mode (ω₁ = π c / 2L)
    c0 = math.sqrt(E / rho)
    alpha = math.pi * c0 / L
    dt = 0.9 * body.stable_time_step()[0]
    n_steps = int(6.0 * (4 * L / c0) / dt)  # six periods of the first mode
    for _ in range(n_steps):
        body.step(dt, f_ext=f_ext - alpha * body.mass[:, None] * body.v, fixed=fixed)
    assert body.kinetic_energy() < 1e-8 * body.strain_energy()
    top = mesh.head_nodes
    shortening = -body.displacement[top, 2].mean()
    A = math.pi * D**2 / 4
    assert shortening / (F * L / (E * A)) == pytest.approx(1.0, abs=0.02)
    # against the polygonal section actually meshed the answer is exact up to the relaxation
    assert shortening / (F * L / (E * A_mesh)) == pytest.approx(1.0, abs=2e-3)
    # Poisson: radial expansion ν ε R on the shaft
    shaft = np.unique(mesh.surface_faces[mesh.face_kind == 1])
    ur = np.sum(body.displacement[shaft, :2] * mesh.nodes[shaft, :2], axis=1) / np.hypot(
        *mesh.nodes[shaft, :2].T
    )
    assert ur.mean() / (nu * F / (E * A_mesh) * D / 2) == pytest.approx(1.0, abs=0.02)


@pytest.mark.parametrize("case", ["bar", "confined"])
def test_longitudinal_wave_speed(case):
    """First axial mode of a free–free slender bar: T = 2L/c with c = √(E/ρ) (bar wave, laterally free) or,
    with every node held laterally (confined column), c = √(M/ρ), M = E(1−ν)/((1+ν)(1−2ν)).
    Expected discretisation error: lumped-mass dispersion (kh)²/24 < 0.1 %, lateral inertia (Rayleigh) < 0.01 %."""
    D, L, E, nu, rho = 0.1, 2.0, 1.0e7, 0.3, 1000.0
    mesh = pile_mesh(PileGeometry(D, L), 0.04, "quarter", n_core=2)
    body = SolidBody.from_mesh(mesh, E, nu, rho)
    fixed = np.zeros((body.n_nodes, 3), bool)
    fixed[mesh.nodes[:, 0] == 0.0, 0] = True
    fixed[mesh.nodes[:, 1] == 0.0, 1] = True
    if case == "confined":
        fixed[:, :2] = True
        c = math.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho)
    else:
        c = math.sqrt(E / rho)
    zeta = (mesh.nodes[:, 2] - mesh.nodes[:, 2].min()) / L
    phi = np.cos(math.pi * zeta)
    v0 = 1e-4 * c
    body.v[:, 2] = v0 * phi
    dt = body.stable_time_step()[0]
    T = 2 * L / c
    m = body.mass
    amp, times = [], []
    for n in range(int(1.3 * T / dt)):
        body.step(dt, fixed=fixed)
        amp.append(np.sum(m * body.v[:, 2] * phi) / np.sum(m * phi * phi))
        times.append((n + 0.5) * dt)  # half-step velocity
    amp, times = np.array(amp), np.array(times)
    k = np.flatnonzero(np.sign(amp[:-1]) != np.sign(amp[1:]))
    assert k.size >= 2
    tz = times[k] + dt * amp[k] / (amp[k] - amp[k + 1])  # linear interpolation of the zero crossings
    T_num = 2.0 * (tz[1] - tz[0])
    assert T_num / T == pytest.approx(1.0, abs=0.005)


def test_rigid_rotation_objectivity():
    """A large rigid rotation (90° about an oblique axis, 200 steps) rotates the pre-stress exactly with the
    body (invariants kept), creates no strain and no hourglass or internal forces beyond round-off."""
    mesh = pile_mesh(PileGeometry(0.6, 1.0, tip="conical"), 0.2, "half", n_core=2)
    E = 2.1e11
    sigma0 = np.array([-120e3, -60e3, -200e3, 35e3, -20e3, 15e3])
    axis, centre = np.array([1.0, 2.0, 3.0]), np.array([0.1, -0.2, 0.3])
    n_steps, total = 200, 0.5 * math.pi
    Rstep = rotation(axis, total / n_steps)
    dt = 1e-4
    bodies = []
    for prestress in (True, False):
        body = SolidBody.from_mesh(mesh, E, 0.3, 7850.0)
        if prestress:
            body.stress[:] = sigma0
        w0 = body.strain_energy()
        allnodes = np.arange(body.n_nodes)
        for _ in range(n_steps):
            v = (body.x - centre) @ (Rstep - np.eye(3)).T / dt
            body.step(dt, prescribed_velocity=(allnodes, v))
        bodies.append((body, w0))
    Rtot = rotation(axis, total)
    (b1, w1), (b0, _) = bodies
    assert np.allclose(b1.x, (mesh.nodes - centre) @ Rtot.T + centre, atol=1e-12)
    expected = Rtot @ vec_to_mat(sigma0) @ Rtot.T
    ev = np.array(
        [expected[0, 0], expected[1, 1], expected[2, 2], expected[0, 1], expected[0, 2], expected[1, 2]]
    )
    s0 = np.abs(sigma0).max()
    assert np.abs(b1.stress - ev).max() < 1e-6 * s0
    inv0 = invariants(sigma0)
    for s in b1.stress[:: max(1, b1.n_elements // 50)]:
        assert np.allclose(invariants(s), inv0, rtol=1e-6)
    assert b1.strain_energy() == pytest.approx(w1, rel=1e-6)
    # without pre-stress: no spurious stress or strain energy at all, no forces from the rotating velocity field
    assert np.abs(b0.stress).max() < 1e-12 * E
    assert b0.strain_energy() < 1e-20 * E * mesh.volume()
    f = b0.internal_forces()
    vmax = np.abs(b0.v).max()
    hg_scale = 0.05 * math.sqrt(E * 7850.0) * 0.1**2 * vmax  # κ √(Mρ) V^{2/3} |v|
    assert np.abs(f).max() < 1e-9 * hg_scale


HOURGLASS_SIGNS = np.array(
    [
        [1, 1, -1, -1, -1, -1, 1, 1],
        [1, -1, -1, 1, -1, 1, 1, -1],
        [1, -1, 1, -1, 1, -1, 1, -1],
        [-1, 1, -1, 1, 1, -1, 1, -1],
    ],
    float,
)  # ηζ, ζξ, ξη, ξηζ at the C3D8 nodes


def _hourglass_field(xe, alpha):
    """Nodal field with zero mean-quadrature gradient: h_α minus its linear part (pure hourglass)."""
    h = HOURGLASS_SIGNS[alpha]
    B, V = gauss_gradients(xe)
    phi = h - (xe - xe.mean(axis=0)) @ (h @ B / V)
    assert np.abs(phi @ B).max() < 1e-12 * np.abs(B).max()
    return phi


def _hourglass_amplitude(xe, ve):
    """‖Σ_I v_I γ_αI‖ over α, γ = h − (h·x) B/V: the part of v no linear field can represent."""
    B, V = gauss_gradients(xe)
    gamma = HOURGLASS_SIGNS - (HOURGLASS_SIGNS @ xe) @ B.T / V
    return np.linalg.norm(gamma @ ve)


def test_hourglass_mode_resisted_rigid_translation_free():
    nodes, hexes = box_mesh(1, 1, 1)
    rng = np.random.default_rng(11)
    nodes = nodes + rng.uniform(-0.12, 0.12, nodes.shape)  # a general (non-parallelepiped) hexahedron
    assert corner_jacobians(nodes, hexes).min() > 0.0
    E, nu, rho = 1.0e7, 0.3, 1000.0
    for alpha in range(4):
        phi = _hourglass_field(nodes[hexes[0]], alpha)
        for kappa in (0.0, 0.05):
            body = SolidBody(nodes, hexes, E, nu, rho, hourglass=kappa)
            body.v[hexes[0]] = 1e-6 * np.outer(phi, [0.3, -1.0, 0.5])  # small: linear regime
            a0 = _hourglass_amplitude(body.x[hexes[0]], body.v[hexes[0]])
            e0 = body.kinetic_energy()
            dt = body.stable_time_step()[0]
            for _ in range(200):
                body.step(dt)
            ratio = _hourglass_amplitude(body.x[hexes[0]], body.v[hexes[0]]) / a0
            energy = (body.kinetic_energy() + body.strain_energy()) / e0
            if kappa == 0.0:  # without control: a zero-energy mode, nothing resists it
                assert ratio == pytest.approx(1.0, abs=1e-3) and energy == pytest.approx(1.0, abs=1e-3)
            else:  # viscous control: the mode is damped out, its energy dissipated
                assert ratio < 1e-2 and energy < 1e-2
    # rigid translation: no force, no stress, kinetic energy and velocity kept exactly
    nodes2, hexes2 = box_mesh(2, 2, 2, distort=0.2, seed=5)
    body = SolidBody(nodes2, hexes2, E, nu, rho)
    u = np.array([0.4, -1.3, 0.7])
    body.v[:] = u
    dt = body.stable_time_step()[0]
    ke0 = body.kinetic_energy()
    for _ in range(200):
        body.step(dt)
    assert np.abs(body.v - u).max() < 1e-12
    assert np.abs(body.stress).max() < 1e-12 * E
    assert body.kinetic_energy() == pytest.approx(ke0, rel=1e-12)
    assert np.allclose(body.x, nodes2 + u * 200 * dt, atol=1e-12)


def _critical_time_step(nodes, hexes, E, nu, rho):
    """2/√λ_max of M⁻¹K for the mesh and the smallest over its elements (element bound), from the
    stiffness assembled here with Gauss-integrated mean gradients and the lumped mass ρV/8."""
    n = nodes.shape[0]
    K = np.zeros((3 * n, 3 * n))
    mass = np.zeros(n)
    dt_el = np.inf
    for e in hexes:
        xe = nodes[e]
        Ke = element_stiffness(xe, E, nu)
        V = gauss_gradients(xe)[1]
        me = np.full(24, rho * V / 8)
        lam_e = np.linalg.eigvalsh(Ke / np.sqrt(np.outer(me, me)))[-1]
        dt_el = min(dt_el, 2 / math.sqrt(lam_e))
        dof = (3 * e[:, None] + np.arange(3)).ravel()
        K[np.ix_(dof, dof)] += Ke
        mass[e] += rho * V / 8
    md = np.repeat(mass, 3)
    lam = np.linalg.eigvalsh(K / np.sqrt(np.outer(md, md)))[-1]
    return 2 / math.sqrt(lam), dt_el


def test_stable_time_step():
    E, nu, rho = 1.0e7, 0.3, 1000.0
    cd = math.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho)
    # single free cube: critical 0.73 h/c_d; the face estimate V/A_max/c_d = h/c_d would be unstable
    cube, hex1 = box_mesh(1, 1, 1)
    dt_crit1, _ = _critical_time_step(cube, hex1, E, nu, rho)
    assert dt_crit1 == pytest.approx(0.733 / cd, rel=0.01)
    assert 1.0 / cd > dt_crit1
    assert SolidBody(cube, hex1, E, nu, rho).stable_time_step()[0] <= dt_crit1

    nodes, hexes = box_mesh(2, 2, 2, size=(1.0, 0.7, 0.4), distort=0.25, seed=2)
    dt_crit, dt_el = _critical_time_step(nodes, hexes, E, nu, rho)
    assert dt_el <= dt_crit * (1 + 1e-12)  # element eigenvalue inequality
    body = SolidBody(nodes, hexes, E, nu, rho)
    dt, e = body.stable_time_step()
    assert 0 <= e < hexes.shape[0]
    assert 0.4 * dt_el < dt <= dt_el  # safe, and not absurdly conservative

    rng = np.random.default_rng(0)
    v0 = 1e-6 * rng.standard_normal(body.v.shape)

    def run(step, n=2000):
        b = SolidBody(nodes, hexes, E, nu, rho)
        b.v[:] = v0
        e0 = b.kinetic_energy()
        emax = e0
        for _ in range(n):
            b.step(step)
            en = b.kinetic_energy() + b.strain_energy()
            if not np.isfinite(en) or en > 1e6 * e0:
                return np.inf
            emax = max(emax, en)
        return emax / e0

    assert run(dt) < 1.05  # stable with the reported step (energy never grows)
    assert run(1.05 * dt_crit) == np.inf  # and the integrator is unstable just above the true limit


def test_parallel_kernels_match_serial():
    """The multi-threaded kernels (used for large bodies) give the same state as the serial ones."""
    mesh = pile_mesh(PileGeometry(0.6, 1.0, tip="conical"), 0.1, "half")
    rng = np.random.default_rng(4)
    v0 = 1e-2 * rng.standard_normal((mesh.nodes.shape[0], 3))
    f_ext = rng.standard_normal((mesh.nodes.shape[0], 3))
    states = []
    for parallel in (False, True):
        body = SolidBody.from_mesh(mesh, 2.0e8, 0.3, 2000.0, parallel=parallel)
        assert body.parallel is parallel
        body.v[:] = v0
        dt = body.stable_time_step()[0]
        for _ in range(20):
            body.step(dt, f_ext=f_ext)
        states.append((body.x.copy(), body.v.copy(), body.stress.copy()))
    for a, b in zip(states[0], states[1], strict=True):
        assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(a).max())


def test_boundary_conditions():
    """Fixed DOFs stay at rest, prescribed components are imposed exactly, NaN components stay free."""
    nodes, hexes = box_mesh(1, 1, 2)
    body = SolidBody(nodes, hexes, 1.0e7, 0.3, 1000.0)
    fixed = np.zeros((body.n_nodes, 3), bool)
    base = np.flatnonzero(nodes[:, 2] == 0.0)
    top = np.flatnonzero(nodes[:, 2] == 1.0)
    fixed[base] = True
    dt = body.stable_time_step()[0]
    for _ in range(50):
        body.step(dt, fixed=fixed, prescribed_velocity=(top, [np.nan, 0.0, -1e-3]))
    assert np.all(body.v[base] == 0.0) and np.all(body.x[base] == nodes[base])
    assert np.all(body.v[top, 1:] == [0.0, -1e-3])
    assert np.allclose(body.displacement[top, 2], -1e-3 * 50 * dt, rtol=1e-12)
    assert np.abs(body.v[top, 0]).max() > 0.0  # lateral expansion under compression is free
    assert np.all(body.stress[:, 2] < 0.0)  # compressed
