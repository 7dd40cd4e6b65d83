"""Pile geometry and a structured hexahedral mesh of the closed-ended pile (DESIGN.md §3, §4.4).

Conventions: SI units, z vertical (up), pile axis = z axis at x = y = 0. The ground surface is z = 0, so a pile
embedded by d has its tip at z_tip = −d; the head is at z_tip + length.

Mesh topology (:func:`pile_mesh`)
---------------------------------
The cross-section is an O-grid ("butterfly"): a core block of n_core × n_core quadrilaterals per quadrant,
surrounded by a ring of n_ring layers of quadrilaterals mapped onto the circle, so that no element
degenerates on the axis (no wedges, no collapsed nodes). Per quadrant, with a = 0.55 R:

* core: a Coons (transfinite) patch bounded by the two symmetry axes (straight, from the centre to (a, 0) and
  (0, a)) and two slightly convex edges, each the average of a straight square edge and an arc of radius a;
  the core corner lies on the diagonal at r ≈ 0.66 R;
* ring: straight radial lines from the 2·n_core + 1 points of the core boundary to the same number of points
  at equal angles on the circle r = R, divided into n_ring equal parts.

The cross-section is built for the quadrant x ≥ 0, y ≥ 0 with nodes *exactly* on x = 0 and y = 0, then
mirrored (x → −x for "half", then y → −y for "full"), merging the nodes of the mirror planes. It is extruded
along z in n_z = round(length/element_size) layers of equal height; hexahedra use the VTK/Abaqus C3D8 node
order (nodes 0-3 counter-clockwise seen from above on the lower level, 4-7 above them), which gives a positive
Jacobian.

Resolution defaults: the circle is a polygon through the mesh nodes; with N = 8·n_core segments around the
full circle the area error is 1 − N sin(2π/N)/(2π) ≈ (2π/N)²/6 and the perimeter error ≈ (π/N)²/6. The default
n_core = max(4, ceil(πR/(4h))) keeps circumferential spacing ≤ h and N ≥ 32, i.e. area (volume) error
< 0.65 % and perimeter (shaft area) error < 0.17 %. n_ring = max(1, round(0.4 R / min(h, s))) with s the
arc spacing, so the ring elements are about square in plan.

Conical tip (``tip="conical"``): the cone of apex angle α has height h_c = R / tan(α/2) and its apex at z_tip.
The flat mesh is built first; then every node at height ζ = z − z_tip below H = min(2 h_c, length) is moved
vertically (x, y unchanged) to ζ' = s(r) + ζ (H − s(r))/H with s(r) = h_c r/R the cone surface. The bottom
level ζ = 0 lands on the cone, ζ = H is unchanged and the layer thickness at r shrinks by (H − s(r))/H ≥ ½
(for H = 2h_c), so elements stay well shaped. On the axis ζ' = ζ, which is why ``layer_z`` is the elevation
of each cross-section level *on the axis*; for a flat tip every node of a level has exactly that z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["PileGeometry", "LevelledMesh", "PileMesh", "pile_mesh", "hex_volumes", "SYMMETRY_FACTOR"]

#: multiplier from the modelled part to the whole pile
SYMMETRY_FACTOR = {"quarter": 4, "half": 2, "full": 1}

#: core half-width as a fraction of the radius, and blend of the core's outer edge towards an arc
_CORE_FRACTION = 0.55
_CORE_BLEND = 0.5
#: default minimum number of core cells per quadrant side (≥ 32 segments around the circle)
_MIN_CORE = 4

#: natural coordinates of the 8 C3D8 nodes
_XI = np.array(
    [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]],
    float,
)


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"PileGeometry: {name} must be finite, got {value!r}")
    return value


@dataclass
class PileGeometry:
    """Closed-ended cylindrical pile on the z axis.

    diameter (m) > 0; length (m) > 0, tip to head, the cone included; tip: "flat" or "conical";
    tip_angle (degrees): apex angle of a conical tip, 0 < α < 180 (default 60, as a CPT cone);
    z_tip (m): initial elevation of the tip (apex), the ground surface being z = 0 (embedment d → z_tip = −d).
    """

    diameter: float
    length: float
    tip: str = "flat"
    tip_angle: float = 60.0
    z_tip: float = 0.0

    def __post_init__(self) -> None:
        self.diameter = _finite("diameter", self.diameter)
        self.length = _finite("length", self.length)
        self.tip_angle = _finite("tip_angle", self.tip_angle)
        self.z_tip = _finite("z_tip", self.z_tip)
        if self.diameter <= 0.0:
            raise ValueError(f"PileGeometry: diameter must be > 0 m, got {self.diameter}")
        if self.length <= 0.0:
            raise ValueError(f"PileGeometry: length must be > 0 m, got {self.length}")
        if self.tip not in ("flat", "conical"):
            raise ValueError(f"PileGeometry: tip must be 'flat' or 'conical', got {self.tip!r}")
        if not 0.0 < self.tip_angle < 180.0:
            raise ValueError(f"PileGeometry: tip_angle must be in (0, 180) degrees, got {self.tip_angle}")
        if self.tip == "conical" and self.cone_height >= self.length:
            raise ValueError(
                f"PileGeometry: the cone (height {self.cone_height:.4g} m for tip_angle {self.tip_angle}°) "
                f"must be shorter than the pile length {self.length} m"
            )

    @classmethod
    def embedded(cls, diameter: float, length: float, embedment: float, **kw: object) -> PileGeometry:
        """Pile whose tip is ``embedment`` m below the ground surface z = 0."""
        return cls(diameter=diameter, length=length, z_tip=-float(embedment), **kw)

    @property
    def radius(self) -> float:
        """R = D/2 (m)."""
        return 0.5 * self.diameter

    @property
    def base_area(self) -> float:
        """π D²/4 (m²), the area q_b refers to (also for a conical tip: its projection)."""
        return 0.25 * math.pi * self.diameter**2

    @property
    def perimeter(self) -> float:
        """Shaft perimeter π D (m)."""
        return math.pi * self.diameter

    @property
    def cone_height(self) -> float:
        """Height of the conical tip R / tan(α/2) (m); 0 for a flat tip."""
        if self.tip != "conical":
            return 0.0
        return self.radius / math.tan(math.radians(0.5 * self.tip_angle))

    @property
    def z_head(self) -> float:
        """Elevation of the pile head (m)."""
        return self.z_tip + self.length


def hex_volumes(nodes: np.ndarray, hexes: np.ndarray) -> np.ndarray:
    """Exact volumes (m³) of trilinear C3D8 hexahedra: 2×2×2 Gauss quadrature of det J, exact because det J
    is at most quadratic in each natural coordinate."""
    xe = np.asarray(nodes, float)[np.asarray(hexes)]  # (m, 8, 3)
    g = 1.0 / math.sqrt(3.0)
    vol = np.zeros(xe.shape[0])
    for a in (-g, g):
        for b in (-g, g):
            for c in (-g, g):
                p = np.array([a, b, c])
                # dN_I/dξ_k = ξ_Ik/8 Π_{l≠k} (1 + ξ_Il p_l)
                f = 1.0 + _XI * p  # (8, 3)
                dn = np.empty((8, 3))
                dn[:, 0] = _XI[:, 0] * f[:, 1] * f[:, 2] / 8.0
                dn[:, 1] = _XI[:, 1] * f[:, 0] * f[:, 2] / 8.0
                dn[:, 2] = _XI[:, 2] * f[:, 0] * f[:, 1] / 8.0
                jac = np.einsum("mIi,Ik->mik", xe, dn)
                vol += np.linalg.det(jac)
    return vol


class LevelledMesh:
    """The levels of a pile mesh (``layer_z`` (n_levels,) elevations, ``layer_of_node`` (n,) each node's level,
    0 at the tip), shared by the 3D and the r–z meshes."""

    layer_z: np.ndarray
    layer_of_node: np.ndarray

    @property
    def n_layers(self) -> int:
        """Number of cross-section levels (element layers + 1)."""
        return int(self.layer_z.shape[0])

    def layer_nodes(self, k: int) -> np.ndarray:
        """Indices of the nodes of cross-section level k (negative k counts from the head)."""
        k = range(self.n_layers)[k]
        return np.flatnonzero(self.layer_of_node == k)

    @property
    def head_nodes(self) -> np.ndarray:
        """Nodes of the top level (the pile head)."""
        return self.layer_nodes(-1)


@dataclass
class PileMesh(LevelledMesh):
    """Hexahedral mesh of a pile (see the module docstring for the topology).

    nodes (n, 3) m; hexes (m, 8) C3D8 order; layer_of_node (n,) index of the cross-section level (0 at the
    tip); layer_z (n_layers,) elevation of each level on the axis (m); surface_faces (k, 4) outward-oriented
    quadrilaterals of the base (face_kind 0) and of the shaft (face_kind 1), none on symmetry planes;
    symmetry: "quarter" (x ≥ 0, y ≥ 0), "half" (y ≥ 0) or "full".
    """

    nodes: np.ndarray
    hexes: np.ndarray
    layer_of_node: np.ndarray
    layer_z: np.ndarray
    surface_faces: np.ndarray
    face_kind: np.ndarray
    symmetry: str
    geometry: PileGeometry | None = None
    n_core: int = 0
    n_ring: int = 0
    section_nodes: int = 0

    @property
    def symmetry_factor(self) -> int:
        """4, 2 or 1: whole pile / modelled part."""
        return SYMMETRY_FACTOR[self.symmetry]

    @property
    def n_elements(self) -> int:
        return int(self.hexes.shape[0])

    def volume(self) -> float:
        """Volume of the modelled part (m³)."""
        return float(hex_volumes(self.nodes, self.hexes).sum())

    def surface_weights(self) -> tuple[np.ndarray, np.ndarray]:
        """Tributary base and shaft areas of every node (m²): a quarter of each adjacent surface face."""
        area = self.face_areas()
        wb = np.zeros(self.nodes.shape[0])
        ws = np.zeros(self.nodes.shape[0])
        for kind, w in ((0, wb), (1, ws)):
            sel = self.face_kind == kind
            np.add.at(w, self.surface_faces[sel].ravel(), np.repeat(area[sel] / 4.0, 4))
        return wb, ws

    def symmetry_nodes(self) -> dict[str, np.ndarray]:
        """Nodes on the symmetry planes: {"x": nodes with x = 0 (fix u_x), "y": nodes with y = 0 (fix u_y)}."""
        out = {"x": np.zeros(0, dtype=np.int64), "y": np.zeros(0, dtype=np.int64)}
        if self.symmetry == "quarter":
            out["x"] = np.flatnonzero(self.nodes[:, 0] == 0.0)
        if self.symmetry in ("quarter", "half"):
            out["y"] = np.flatnonzero(self.nodes[:, 1] == 0.0)
        return out

    def face_areas(self) -> np.ndarray:
        """Areas of the surface faces (m²), bilinear quadrilaterals (2×2 Gauss quadrature)."""
        p = self.nodes[self.surface_faces]  # (k, 4, 3)
        g = 1.0 / math.sqrt(3.0)
        area = np.zeros(p.shape[0])
        s_ = np.array([-1.0, 1.0, 1.0, -1.0])
        t_ = np.array([-1.0, -1.0, 1.0, 1.0])
        for s in (-g, g):
            for t in (-g, g):
                ds = np.einsum("kIi,I->ki", p, s_ * (1.0 + t_ * t) / 4.0)
                dt = np.einsum("kIi,I->ki", p, t_ * (1.0 + s_ * s) / 4.0)
                area += np.linalg.norm(np.cross(ds, dt), axis=1)
        return area


def _quarter_section(radius: float, nc: int, nr: int):
    """2-D O-grid of the quadrant x ≥ 0, y ≥ 0: node coordinates (p, 2), CCW quads (q, 4), on-circle flags."""
    a = _CORE_FRACTION * radius
    beta = _CORE_BLEND

    def right_edge(v: float) -> tuple[float, float]:
        th = 0.25 * math.pi * v
        return ((1.0 - beta) * a + beta * a * math.cos(th), (1.0 - beta) * a * v + beta * a * math.sin(th))

    def top_edge(u: float) -> tuple[float, float]:
        y, x = right_edge(u)
        return x, y

    corner = right_edge(1.0)
    pts: list[tuple[float, float]] = []
    core = np.empty((nc + 1, nc + 1), dtype=np.int64)
    for j in range(nc + 1):
        v = j / nc
        for i in range(nc + 1):
            u = i / nc
            rx, ry = right_edge(v)
            tx, ty = top_edge(u)
            # Coons patch: left (0, a v), right R(v), bottom (a u, 0), top T(u); corners (0,0) (a,0) (0,a) P11
            x = u * rx + (1.0 - v) * a * u + v * tx - (u * (1.0 - v) * a + u * v * corner[0])
            y = (1.0 - u) * a * v + u * ry + v * ty - ((1.0 - u) * v * a + u * v * corner[1])
            if i == 0:
                x = 0.0
            if j == 0:
                y = 0.0
            core[i, j] = len(pts)
            pts.append((x, y))
    quads = [
        (core[i, j], core[i + 1, j], core[i + 1, j + 1], core[i, j + 1]) for j in range(nc) for i in range(nc)
    ]
    # ring: path along the core boundary from (a, 0) through the corner to (0, a)
    ns = 2 * nc + 1
    ring = np.empty((ns, nr + 1), dtype=np.int64)
    on_circle = [False] * len(pts)
    for s in range(ns):
        ring[s, 0] = core[nc, s] if s <= nc else core[2 * nc - s, nc]
        px, py = pts[ring[s, 0]]
        th = 0.5 * math.pi * s / (2 * nc)
        qx, qy = radius * math.cos(th), radius * math.sin(th)
        if s == 0:
            qx, qy = radius, 0.0
        if s == 2 * nc:
            qx, qy = 0.0, radius
        for l in range(1, nr + 1):
            if l == nr:
                x, y = qx, qy
            else:
                t = l / nr
                x, y = px + t * (qx - px), py + t * (qy - py)
                if s == 0:
                    y = 0.0
                if s == 2 * nc:
                    x = 0.0
            ring[s, l] = len(pts)
            pts.append((x, y))
            on_circle.append(l == nr)
    quads += [
        (ring[s, l], ring[s, l + 1], ring[s + 1, l + 1], ring[s + 1, l])
        for s in range(ns - 1)
        for l in range(nr)
    ]
    return np.array(pts, float), np.array(quads, dtype=np.int64), np.array(on_circle, bool)


def _mirror(pts: np.ndarray, quads: np.ndarray, circ: np.ndarray, axis: int):
    """Add the mirror image x_axis → −x_axis; nodes exactly on the plane are shared; quads keep CCW order."""
    on_plane = pts[:, axis] == 0.0
    new = np.flatnonzero(~on_plane)
    image = np.arange(pts.shape[0])
    image[new] = pts.shape[0] + np.arange(new.size)
    mp = pts[new].copy()
    mp[:, axis] = -mp[:, axis]
    mq = image[quads][:, ::-1]  # reflection reverses the orientation: (0,1,2,3) → (3,2,1,0)
    return np.vstack([pts, mp]), np.vstack([quads, mq]), np.concatenate([circ, circ[new]])


def pile_mesh(
    geometry: PileGeometry,
    element_size: float,
    symmetry: str = "quarter",
    n_core: int | None = None,
    *,
    n_ring: int | None = None,
    axial_size: float | None = None,
) -> PileMesh:
    """Structured O-grid hexahedral mesh of the closed-ended pile (see the module docstring).

    element_size (m): target size h along z and around the circumference; symmetry: "quarter" | "half" |
    "full"; n_core: core cells per quadrant side (default max(4, ceil(πR/(4h)))); n_ring: ring element
    layers (default max(1, round(0.4R/min(h, πR/(4 n_core))))); axial_size (m): element height along z
    (default h).
    """
    if not isinstance(geometry, PileGeometry):
        raise TypeError("pile_mesh: geometry must be a PileGeometry")
    h = float(element_size)
    if not math.isfinite(h) or h <= 0.0:
        raise ValueError(
            f"pile_mesh: element_size must be a finite positive length (m), got {element_size!r}"
        )
    if symmetry not in SYMMETRY_FACTOR:
        raise ValueError(f"pile_mesh: symmetry must be one of {tuple(SYMMETRY_FACTOR)}, got {symmetry!r}")
    R = geometry.radius
    if n_core is None:
        n_core = max(_MIN_CORE, math.ceil(0.25 * math.pi * R / h - 1e-9))
    n_core = int(n_core)
    if n_core < 1:
        raise ValueError(f"pile_mesh: n_core must be >= 1, got {n_core}")
    s_arc = 0.25 * math.pi * R / n_core
    if n_ring is None:
        n_ring = max(1, round(0.4 * R / min(h, s_arc)))
    n_ring = int(n_ring)
    if n_ring < 1:
        raise ValueError(f"pile_mesh: n_ring must be >= 1, got {n_ring}")

    pts, quads, circ = _quarter_section(R, n_core, n_ring)
    if symmetry in ("half", "full"):
        pts, quads, circ = _mirror(pts, quads, circ, 0)
    if symmetry == "full":
        pts, quads, circ = _mirror(pts, quads, circ, 1)
    # CCW check of the section (positive signed area of every quad)
    p = pts[quads]
    area2 = (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 3, 1] - p[:, 1, 1]) - (p[:, 2, 1] - p[:, 0, 1]) * (
        p[:, 3, 0] - p[:, 1, 0]
    )
    if np.any(area2 <= 0.0):  # pragma: no cover - construction invariant
        raise RuntimeError("pile_mesh: cross-section quadrilateral with non-positive area")

    hz = h if axial_size is None else float(axial_size)
    if not math.isfinite(hz) or hz <= 0.0:
        raise ValueError(f"pile_mesh: axial_size must be a finite positive length (m), got {axial_size!r}")
    nz = max(1, round(geometry.length / hz))
    layer_z = geometry.z_tip + geometry.length * np.arange(nz + 1) / nz
    layer_z[-1] = geometry.z_head
    n2 = pts.shape[0]
    nodes = np.empty(((nz + 1) * n2, 3))
    for k in range(nz + 1):
        nodes[k * n2 : (k + 1) * n2, :2] = pts
        nodes[k * n2 : (k + 1) * n2, 2] = layer_z[k]
    layer_of_node = np.repeat(np.arange(nz + 1), n2)
    hexes = np.concatenate([np.hstack([quads + k * n2, quads + (k + 1) * n2]) for k in range(nz)])

    # outward surface faces: base (lower level of layer 0, reversed) and shaft (quad edges on the circle)
    base = quads[:, ::-1]
    edges = []
    for c in range(4):
        a_, b_ = quads[:, c], quads[:, (c + 1) % 4]
        sel = circ[a_] & circ[b_]
        edges.append(np.stack([a_[sel], b_[sel]], axis=1))
    edges = np.concatenate(edges)
    shaft = np.concatenate(
        [
            np.stack(
                [
                    edges[:, 0] + k * n2,
                    edges[:, 1] + k * n2,
                    edges[:, 1] + (k + 1) * n2,
                    edges[:, 0] + (k + 1) * n2,
                ],
                1,
            )
            for k in range(nz)
        ]
    )
    faces = np.vstack([base, shaft]).astype(np.int64)
    kind = np.concatenate([np.zeros(base.shape[0], np.int8), np.ones(shaft.shape[0], np.int8)])

    if geometry.tip == "conical":
        hc = geometry.cone_height
        H = min(2.0 * hc, geometry.length)
        r = np.minimum(np.hypot(nodes[:, 0], nodes[:, 1]), R)
        zeta = nodes[:, 2] - geometry.z_tip
        sel = zeta < H
        s = hc * r[sel] / R
        nodes[sel, 2] = geometry.z_tip + s + zeta[sel] * (H - s) / H

    return PileMesh(
        nodes=nodes,
        hexes=hexes.astype(np.int64),
        layer_of_node=layer_of_node.astype(np.int64),
        layer_z=layer_z,
        surface_faces=faces,
        face_kind=kind,
        symmetry=symmetry,
        geometry=geometry,
        n_core=n_core,
        n_ring=n_ring,
        section_nodes=n2,
    )
