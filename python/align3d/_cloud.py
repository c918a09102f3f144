"""PointCloud, the file readers and writers, and 4x4 transforms."""

from __future__ import annotations

import os
import warnings
from typing import Any, Optional, Union

import numpy as np

from . import _core
from ._errors import AlignWarning

PathLike = Union[str, "os.PathLike[str]"]


def rows(name: str, value: Any, count: Optional[int] = None) -> np.ndarray:
    """``value`` as a C-contiguous float64 (N, 3) array, without a copy when it already is one.

    Integer arrays are converted to float64; any other dtype (bool, complex, object, text) or
    shape is a ValueError naming the argument. Finiteness is the library's check (a DataError).
    """
    a = np.asarray(value)
    if a.dtype.kind not in "fiu":
        raise ValueError(
            f"{name}: expected real numbers (a float or integer array), got dtype {a.dtype}"
        )
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name}: expected an array of shape (N, 3), got shape {a.shape}")
    if count is not None and a.shape[0] != count:
        raise ValueError(f"{name}: {a.shape[0]} rows for a cloud of {count} points")
    return np.ascontiguousarray(a, dtype=np.float64)


def matrix(name: str, value: Any) -> np.ndarray:
    """``value`` as a float64 4x4 array (ValueError otherwise); rigidity is the library's check."""
    a = np.asarray(value)
    if a.dtype.kind not in "fiu":
        raise ValueError(f"{name}: expected a real 4x4 matrix, got dtype {a.dtype}")
    if a.shape != (4, 4):
        raise ValueError(f"{name}: expected a 4x4 matrix, got shape {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float64)


class PointCloud:
    """Points and optional unit normals, in the data's units (mm, m, ...).

    ``PointCloud(points, normals=None)`` takes (N, 3) arrays (or anything ``numpy.asarray``
    turns into one). Floating-point and integer arrays are accepted; integers are converted to
    float64. Another dtype or shape is a ``ValueError``; a NaN or Inf coordinate is a
    :class:`DataError` (drop such rows first: ``p[np.isfinite(p).all(axis=1)]``). Normals are
    normalised to unit length (a zero one is a DataError).

    The cloud owns its data: the arrays are copied in once, into the C++ cloud. ``points`` and
    ``normals`` are views of that storage (no copy, writable: writing into them changes the
    cloud). A cloud never changes size; assigning to ``points`` or ``normals`` writes the new
    values into the same storage, so views taken before see them.
    """

    __slots__ = ("_cloud",)

    def __init__(self, points: Any, normals: Any = None) -> None:
        p = rows("points", points)
        n = None if normals is None else rows("normals", normals, len(p))
        self._cloud = _core.PointCloud(p, n)

    @classmethod
    def _wrap(cls, cloud: "_core.PointCloud") -> "PointCloud":
        self = cls.__new__(cls)
        self._cloud = cloud
        return self

    @property
    def points(self) -> np.ndarray:
        """(N, 3) float64 view of the positions (writable; no copy)."""
        return self._cloud.points

    @points.setter
    def points(self, value: Any) -> None:
        self._cloud.set_points(rows("points", value, len(self)))

    @property
    def normals(self) -> Optional[np.ndarray]:
        """(N, 3) float64 view of the unit normals, or None when the cloud has none."""
        return self._cloud.normals

    @normals.setter
    def normals(self, value: Any) -> None:
        self._cloud.set_normals(rows("normals", value, len(self)))

    @property
    def has_normals(self) -> bool:
        """True when every point has a normal."""
        return self._cloud.has_normals

    def __len__(self) -> int:
        return len(self._cloud)

    def __repr__(self) -> str:
        normals = " with normals" if self.has_normals else ""
        return f"<align3d.PointCloud of {len(self)} points{normals}>"

    def transformed(self, transformation: Any) -> "PointCloud":
        """A new cloud: T·cloud (positions moved rigidly, normals rotated). ``transformation`` is
        a 4x4 rigid matrix, row-major, as :attr:`Result.transformation`; a matrix that is not
        rigid is a :class:`SettingsError`."""
        return PointCloud._wrap(self._cloud.transformed(matrix("transformation", transformation)))

    def copy(self) -> "PointCloud":
        """A new cloud with its own copy of the data."""
        return PointCloud._wrap(self._cloud.copy())


def as_cloud(value: Any) -> PointCloud:
    """A PointCloud as given, or built from an (N, 3) array."""
    return value if isinstance(value, PointCloud) else PointCloud(value)


def read_point_cloud(path: PathLike) -> PointCloud:
    """Reads a cloud; the format is the extension (case-insensitive): ``.ply`` (ascii and binary;
    normals when present), ``.pcd`` (ascii, binary, binary_compressed), ``.xyz``/``.txt``/
    ``.csv`` (three numbers a row). Points with a NaN or Inf coordinate are dropped with an
    :class:`AlignWarning` (code ``file``). A missing, unreadable, malformed or truncated file is a
    :class:`FileError` naming it (and the line or byte offset); one with no point left too.
    The GIL is released while reading."""
    return _read(path, stacklevel=3)[0]


def _read(path: PathLike, stacklevel: int) -> "tuple[PointCloud, Optional[np.ndarray]]":
    """The cloud of a file and its sensor's position where the file gives one (a PCD's VIEWPOINT
    away from the origin, the origin of an organized PCD), else None; the warning about dropped
    points is issued ``stacklevel`` frames up."""
    cloud, dropped, viewpoint = _core.read_point_cloud(os.fspath(path))
    if dropped:
        warnings.warn(
            AlignWarning(
                "file", f"{os.fspath(path)}: dropped {dropped} points with NaN or Inf coordinates"
            ),
            stacklevel=stacklevel,
        )
    eye = None if viewpoint is None else np.asarray(viewpoint, dtype=np.float64)
    return PointCloud._wrap(cloud), eye


def write_point_cloud(path: PathLike, cloud: Any, *, encoding: Optional[str] = None) -> None:
    """Writes ``cloud`` (a PointCloud or an (N, 3) array) by the extension of ``path``, atomically
    (the file holds the whole new cloud or what it held before). Coordinates are float32 in PLY
    and PCD, ``%.9g`` text in ``.xyz``/``.txt``/``.csv``; normals are written where the format
    holds them. ``encoding``: PLY ``ascii``, ``binary`` (little-endian, the default) or
    ``binary_big_endian``; PCD ``ascii``, ``binary`` (the default) or ``binary_compressed``; text
    formats have none (a :class:`SettingsError`). A write that fails is a :class:`FileError`."""
    _core.write_point_cloud(os.fspath(path), as_cloud(cloud)._cloud, encoding or "")


def read_matrix(path: PathLike) -> np.ndarray:
    """Reads a 4x4 rigid transform file (4 rows of 4 numbers, ``#`` comments; the format of
    ``ground_truth.txt`` and of ``--init FILE``) as a 4x4 float64 array. Anything else (not rigid,
    wrong size, not numbers) is a :class:`FileError` naming the file and the line."""
    return np.asarray(_core.read_matrix(os.fspath(path)))


def write_matrix(path: PathLike, transformation: Any) -> None:
    """Writes a 4x4 rigid transform (17 significant digits: read back exactly), atomically."""
    _core.write_matrix(os.fspath(path), matrix("transformation", transformation))
