"""TriangleMesh and the mesh files (CAD models)."""

from __future__ import annotations

import os
import warnings
from typing import Any, Dict

import numpy as np

from . import _core
from ._cloud import PathLike, PointCloud, rows
from ._errors import AlignWarning


def _triangles(value: Any) -> np.ndarray:
    a = np.asarray(value)
    if a.dtype.kind not in "iu":
        raise ValueError(f"triangles: expected an integer array, got dtype {a.dtype}")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"triangles: expected an array of shape (M, 3), got shape {a.shape}")
    if a.dtype.kind == "u" and a.size and a.max() > np.iinfo(np.int64).max:
        raise ValueError("triangles: an index does not fit in 64 bits")
    return np.ascontiguousarray(a, dtype=np.int64)


def _read_only(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


class TriangleMesh:
    """A triangle mesh (a CAD model), in the data's units.

    ``TriangleMesh(vertices, triangles)`` takes an (N, 3) array of vertices (float or integer)
    and an (M, 3) integer array of vertex indices, 0-based; a triangle (a, b, c) faces the side
    its normal (b − a) × (c − a) points to. A wrong dtype or shape is a ``ValueError``; an index
    out of range or a NaN/Inf vertex is a :class:`DataError`. Meshes as files store them (STL
    repeats every vertex, windings may disagree) are cleaned where they are measured: identical
    vertices welded, degenerate triangles dropped, windings made consistent and outward
    (:meth:`cleaned`, :meth:`topology`).

    ``vertices`` and ``triangles`` are read-only views of the mesh's storage (uint32 indices).
    """

    __slots__ = ("_mesh",)

    def __init__(self, vertices: Any, triangles: Any) -> None:
        self._mesh = _core.TriangleMesh(rows("vertices", vertices), _triangles(triangles))

    @classmethod
    def _wrap(cls, mesh: "_core.TriangleMesh") -> "TriangleMesh":
        self = cls.__new__(cls)
        self._mesh = mesh
        return self

    @property
    def vertices(self) -> np.ndarray:
        """(N, 3) float64, read-only view."""
        return _read_only(self._mesh.vertices)

    @property
    def triangles(self) -> np.ndarray:
        """(M, 3) uint32 vertex indices, read-only view."""
        return _read_only(self._mesh.triangles)

    def __len__(self) -> int:
        """The number of triangles."""
        return len(self._mesh.triangles)

    def __repr__(self) -> str:
        return (
            f"<align3d.TriangleMesh of {len(self)} triangles, "
            f"{len(self._mesh.vertices)} vertices>"
        )

    def area(self) -> float:
        """The surface area (data units²)."""
        return self._mesh.area()

    def diagonal(self) -> float:
        """The bounding-box diagonal of the vertices in use: the part's size."""
        return self._mesh.diagonal()

    def topology(self) -> Dict[str, Any]:
        """``closed``, ``boundary_edges``, ``non_manifold_edges``, ``inconsistent_edges``
        (windings that disagree), ``components``, ``signed_volume``, ``vertices``, ``triangles``,
        counted on this mesh as it is (weld an STL first: :meth:`cleaned`)."""
        return self._mesh.topology()

    def cleaned(self) -> "TriangleMesh":
        """A new mesh as align3d measures it: identical vertices welded, zero-area and duplicate
        triangles dropped, each piece wound consistently and, when closed, outward."""
        return TriangleMesh._wrap(self._mesh.cleaned())

    def sample(self, count: int, *, seed: int = 1) -> PointCloud:
        """``count`` points spread evenly by area, each with its triangle's normal (the same
        mesh, count and seed give the same points)."""
        return PointCloud._wrap(self._mesh.sample(int(count), int(seed)))


def is_mesh_file(path: PathLike) -> bool:
    """Whether align3d reads ``path`` as a mesh: .stl, .obj, .off, .step/.stp/.iges/.igs (when
    built with OpenCASCADE), or a .ply whose header declares faces."""
    return _core.is_mesh_file(os.fspath(path))


def read_mesh(path: PathLike, *, chord_tolerance: float = 0.0) -> TriangleMesh:
    """Reads a mesh by its extension (case-insensitive): ``.stl`` (binary or ASCII), ``.obj``,
    ``.off``, ``.ply`` with faces, and ``.step``/``.stp``/``.iges``/``.igs`` tessellated by
    OpenCASCADE to ``chord_tolerance`` (data units; 0: 1e-4 × the part's diagonal) when align3d
    was built with it. Polygons are fanned into triangles; faces with a repeated corner are
    dropped with an :class:`AlignWarning`. A missing, malformed or truncated file, an index out of
    range, or a file without triangles is a :class:`FileError` naming it (and the line or byte
    offset). The GIL is released while reading."""
    if isinstance(chord_tolerance, bool) or not isinstance(chord_tolerance, (int, float)):
        raise TypeError("chord_tolerance: expected a number")
    mesh, _, _, dropped = _core.read_mesh(os.fspath(path), float(chord_tolerance))
    if dropped:
        warnings.warn(
            AlignWarning("file", f"{os.fspath(path)}: dropped {dropped} faces with fewer than 3 "
                                 "distinct corners"),
            stacklevel=2,
        )
    return TriangleMesh._wrap(mesh)


def write_mesh(path: PathLike, mesh: TriangleMesh) -> None:
    """Writes a mesh by extension, atomically: ``.stl`` (binary, float32), ``.ply`` (binary,
    float64 vertices), ``.obj``, ``.off``. A write that fails is a :class:`FileError`."""
    if not isinstance(mesh, TriangleMesh):
        raise TypeError(f"mesh: expected a TriangleMesh, got {type(mesh).__name__}")
    _core.write_mesh(os.fspath(path), mesh._mesh)
