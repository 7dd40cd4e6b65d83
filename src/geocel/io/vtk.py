"""Field snapshots for ParaView: VTK XML files written with pyevtk and a ``.pvd`` time series.

- :func:`write_rectilinear`: the Eulerian grid (``.vtr``), node coordinates per axis, cell and node data.
- :func:`write_rectilinear_rz`: the r–z plane of an axisymmetric model as a 2D grid (``.vtr``, x = r, y = 0).
- :func:`write_structured`: a curvilinear grid (``.vts``: the cylindrical layout's sectors), node coordinates
  per node.
- :func:`write_unstructured_hex`: Lagrangian bodies of 8-node hexahedra (``.vtu``).
- :class:`PvdSeries`: the ParaView collection file listing the snapshots by time (and part/body).

Data arrays: scalars have the shape of the cells (or nodes); vectors a trailing axis of 3 (written as
VTK 3-component arrays); symmetric tensors a trailing axis of 6 in the order 11, 22, 33, 12, 13, 23 of
DESIGN.md §3 (tensor components), written as six scalars ``name_xx, name_yy, name_zz, name_xy, name_xz,
name_yz``. Booleans are written as uint8. Each file is written under a temporary name and moved into
place, so a killed run never leaves a truncated snapshot listed in the series.
"""

from __future__ import annotations

import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
from pyevtk.hl import gridToVTK, unstructuredGridToVTK

__all__ = [
    "TENSOR_SUFFIXES",
    "VTK_HEXAHEDRON",
    "PvdSeries",
    "write_rectilinear",
    "write_rectilinear_rz",
    "write_structured",
    "write_unstructured_hex",
]

VTK_HEXAHEDRON = 12
#: names of the 6 tensor components, in the storage order 11, 22, 33, 12, 13, 23
TENSOR_SUFFIXES = ("xx", "yy", "zz", "xy", "xz", "yz")
_SUPPORTED = {"int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "float32", "float64"}


def _as_vtk_dtype(a: np.ndarray) -> np.ndarray:
    if a.dtype == np.bool_:
        return a.astype(np.uint8)
    if a.dtype.name not in _SUPPORTED:
        return a.astype(np.float64)
    return a


def _prepare(
    data: Mapping[str, np.ndarray] | None, shape: tuple[int, ...], what: str
) -> dict[str, np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Split vectors/tensors into what pyevtk takes: contiguous scalars and 3-tuples of scalars."""
    out: dict[str, np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    for name, value in (data or {}).items():
        a = _as_vtk_dtype(np.asarray(value))
        if a.shape == shape:
            out[name] = np.ascontiguousarray(a)
        elif a.shape == (*shape, 3):
            out[name] = tuple(np.ascontiguousarray(a[..., k]) for k in range(3))  # type: ignore[assignment]
        elif a.shape == (*shape, 6):
            for k, suffix in enumerate(TENSOR_SUFFIXES):
                out[f"{name}_{suffix}"] = np.ascontiguousarray(a[..., k])
        else:
            raise ValueError(
                f"{what} {name!r} has shape {a.shape}; expected {shape}, {(*shape, 3)} or {(*shape, 6)}"
            )
    for name in out:
        if not name or any(c in name for c in '<>&"'):
            raise ValueError(f"{what} name {name!r} is not a valid VTK array name")
    return out


def _finish(tmp_written: str, final: Path) -> Path:
    os.replace(tmp_written, final)
    return final


def write_rectilinear(
    path_without_ext: str | Path,
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    cell_data: Mapping[str, np.ndarray],
    point_data: Mapping[str, np.ndarray] | None = None,
) -> Path:
    """Write a rectilinear grid (``.vtr``) and return its path.

    ``x, y, z``: node coordinates along each axis, m (lengths nx+1, ny+1, nz+1). ``cell_data``: arrays of
    shape (nx, ny, nz[, 3 | 6]); ``point_data``: shape (nx+1, ny+1, nz+1[, 3 | 6])."""
    xs, ys, zs = (np.ascontiguousarray(np.asarray(c, dtype=np.float64)) for c in (x, y, z))
    if xs.ndim != 1 or ys.ndim != 1 or zs.ndim != 1 or min(xs.size, ys.size, zs.size) < 2:
        raise ValueError("x, y, z must be 1-D node coordinate arrays with at least 2 entries each")
    cells = (xs.size - 1, ys.size - 1, zs.size - 1)
    nodes = (xs.size, ys.size, zs.size)
    cd = _prepare(cell_data, cells, "cell array")
    pd = _prepare(point_data, nodes, "point array")
    final = Path(str(path_without_ext) + ".vtr")
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = str(path_without_ext) + ".tmp"
    written = gridToVTK(tmp, xs, ys, zs, cellData=cd or None, pointData=pd or None)
    return _finish(written, final)


def write_structured(
    path_without_ext: str | Path,
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    cell_data: Mapping[str, np.ndarray],
    point_data: Mapping[str, np.ndarray] | None = None,
) -> Path:
    """Write a structured (curvilinear) grid (``.vts``) and return its path.

    ``x, y, z``: node coordinates, m, each of shape (n1+1, n2+1, n3+1). ``cell_data``: arrays of shape
    (n1, n2, n3[, 3 | 6]); ``point_data``: (n1+1, n2+1, n3+1[, 3 | 6])."""
    xs, ys, zs = (np.ascontiguousarray(np.asarray(c, dtype=np.float64)) for c in (x, y, z))
    if xs.ndim != 3 or xs.shape != ys.shape or xs.shape != zs.shape or min(xs.shape) < 2:
        raise ValueError("x, y, z must be 3-D node coordinate arrays of one shape, ≥ 2 nodes per direction")
    nodes = xs.shape
    cells = tuple(n - 1 for n in nodes)
    cd = _prepare(cell_data, cells, "cell array")
    pd = _prepare(point_data, nodes, "point array")
    final = Path(str(path_without_ext) + ".vts")
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = str(path_without_ext) + ".tmp"
    written = gridToVTK(tmp, xs, ys, zs, cellData=cd or None, pointData=pd or None)
    return _finish(written, final)


def write_rectilinear_rz(
    path_without_ext: str | Path,
    r: np.ndarray,
    z: np.ndarray,
    cell_data: Mapping[str, np.ndarray],
    point_data: Mapping[str, np.ndarray] | None = None,
) -> Path:
    """Write the r–z plane of an axisymmetric model as a 2D rectilinear grid (``.vtr``, one node layer in y:
    ParaView shows quads in its x–z plane, x = r) and return its path.

    ``r, z``: node coordinates, m (nr+1, nz+1). ``cell_data``: arrays of shape (nr, nz[, 3 | 6]);
    ``point_data``: (nr+1, nz+1[, 2 | 3 | 6]), a 2-vector (r, z) written as the 3-vector (r, 0, z)."""
    rs, zs = (np.ascontiguousarray(np.asarray(c, dtype=np.float64)) for c in (r, z))
    if rs.ndim != 1 or zs.ndim != 1 or min(rs.size, zs.size) < 2:
        raise ValueError("r, z must be 1-D node coordinate arrays with at least 2 entries each")

    def plane(data: Mapping[str, np.ndarray] | None, shape: tuple[int, int]) -> dict[str, np.ndarray]:
        out = {}
        for name, value in (data or {}).items():
            a = np.asarray(value)
            if a.shape == (*shape, 2):
                a = np.stack([a[..., 0], np.zeros(shape), a[..., 1]], axis=-1)
            out[name] = a.reshape(shape[0], 1, shape[1], *a.shape[2:])
        return out

    cells = (rs.size - 1, zs.size - 1)
    nodes = (rs.size, zs.size)
    cd = _prepare(plane(cell_data, cells), (cells[0], 1, cells[1]), "cell array")
    pd = _prepare(plane(point_data, nodes), (nodes[0], 1, nodes[1]), "point array")
    final = Path(str(path_without_ext) + ".vtr")
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = str(path_without_ext) + ".tmp"
    written = gridToVTK(tmp, rs, np.zeros(1), zs, cellData=cd or None, pointData=pd or None)
    return _finish(written, final)


def write_unstructured_hex(
    path_without_ext: str | Path,
    points: np.ndarray,
    hexes: np.ndarray,
    cell_data: Mapping[str, np.ndarray] | None = None,
    point_data: Mapping[str, np.ndarray] | None = None,
) -> Path:
    """Write 8-node hexahedra (``.vtu``, VTK_HEXAHEDRON node order) and return its path.

    ``points``: (n, 3) node coordinates, m; ``hexes``: (m, 8) node indices; ``cell_data``: arrays of
    shape (m[, 3 | 6]); ``point_data``: shape (n[, 3 | 6])."""
    pts = np.asarray(points, dtype=np.float64)
    conn = np.asarray(hexes)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {pts.shape}")
    if conn.ndim != 2 or conn.shape[1] != 8 or not np.issubdtype(conn.dtype, np.integer):
        raise ValueError(f"hexes must be an integer array of shape (m, 8), got {conn.shape} {conn.dtype}")
    if conn.size and (conn.min() < 0 or conn.max() >= len(pts)):
        raise ValueError(f"hexes refer to nodes outside 0..{len(pts) - 1}")
    m = conn.shape[0]
    cd = _prepare(cell_data, (m,), "cell array")
    pd = _prepare(point_data, (len(pts),), "point array")
    x, y, z = (np.ascontiguousarray(pts[:, k]) for k in range(3))
    connectivity = np.ascontiguousarray(conn.astype(np.int64).ravel())
    offsets = np.arange(8, 8 * m + 1, 8, dtype=np.int64)
    types = np.full(m, VTK_HEXAHEDRON, dtype=np.uint8)
    final = Path(str(path_without_ext) + ".vtu")
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = str(path_without_ext) + ".tmp"
    written = unstructuredGridToVTK(
        tmp, x, y, z, connectivity, offsets, types, cellData=cd or None, pointData=pd or None
    )
    return _finish(written, final)


class PvdSeries:
    """A ParaView ``.pvd`` collection: (time, part, file) entries, rewritten atomically on each change.

    File paths are stored relative to the ``.pvd``. An existing file is read on construction, so a
    restarted run continues the series (use :meth:`drop_after` to forget snapshots past the restart)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.entries: list[tuple[float, int, str]] = []
        if self.path.is_file():
            root = ET.parse(self.path).getroot()
            for ds in root.iter("DataSet"):
                self.entries.append(
                    (float(ds.get("timestep", "0")), int(ds.get("part", "0")), ds.get("file", ""))
                )
            self._sort()

    def _sort(self) -> None:
        self.entries.sort(key=lambda e: (e[0], e[1]))

    def _relative(self, file: str | Path) -> str:
        file = Path(file)
        if not file.is_absolute():
            file = Path.cwd() / file
        return Path(os.path.relpath(file.resolve(), self.path.parent.resolve())).as_posix()

    def add(self, time: float, file: str | Path, part: int = 0) -> None:
        """Add a snapshot at ``time`` (s) for body ``part``; replaces an entry of the same file or time+part."""
        rel = self._relative(file)
        t = float(time)
        self.entries = [e for e in self.entries if e[2] != rel and not (e[0] == t and e[1] == part)]
        self.entries.append((t, int(part), rel))
        self._sort()
        self.write()

    def drop_after(self, time: float) -> None:
        """Forget the snapshots later than ``time`` (s), e.g. on a restart from a checkpoint."""
        self.entries = [e for e in self.entries if e[0] <= time]
        self.write()

    @property
    def times(self) -> list[float]:
        """Times of the entries (s), sorted."""
        return [e[0] for e in self.entries]

    @property
    def files(self) -> list[Path]:
        """Paths of the entries (relative to the current directory as the ``.pvd`` is), in time order."""
        return [self.path.parent / e[2] for e in self.entries]

    def write(self) -> None:
        """Rewrite the ``.pvd`` (temporary file + ``os.replace``)."""
        order = "LittleEndian" if sys.byteorder == "little" else "BigEndian"
        lines = [
            '<?xml version="1.0"?>',
            f'<VTKFile type="Collection" version="0.1" byte_order="{order}">',
            "  <Collection>",
        ]
        for t, part, rel in self.entries:
            lines.append(f'    <DataSet timestep="{t!r}" group="" part="{part}" file={quoteattr(rel)}/>')
        lines += ["  </Collection>", "</VTKFile>", ""]
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(self.path.name + ".tmp")
        tmp.write_text("\n".join(lines), encoding="utf-8")
        os.replace(tmp, self.path)

    def __len__(self) -> int:
        return len(self.entries)
