"""Target: a registration target prepared once for many sources (the library's PreparedTarget)."""

from __future__ import annotations

import os
from typing import Any, Union

import numpy as np

from . import _core
from ._cloud import PathLike, PointCloud, as_cloud, read_point_cloud

_DEFAULT_K = _core.defaults()["register"]["normal_k"]


class Target:
    """A target (the model) prepared once for many :func:`register` calls: its kd-tree, every
    normal, its scale and, built by the first source that needs them, the global stage's FPFH
    descriptors and PPF model (the library's ``PreparedTarget``, align3d/prepared_target.hpp).

    ``register(scan, Target(model))`` returns the pose ``register(scan, model)`` returns, to the
    bit, without rebuilding what depends on the model alone: a line that registers thousands of
    scans against a few models prepares each once. One Target may serve several Python threads
    at once (the GIL is released while it is built and used).

    cloud: a :class:`PointCloud`, an (N, 3) array or a file name (reports then show the path); or
    a :class:`TriangleMesh` or a mesh file (a CAD model: registered onto its exact surface, and
    the CAD model of :func:`inspect`).
    normal_k: neighbours of the PCA normals (the ``normal_k`` of the registrations that use it).
    threads: for the preparation (0: every core).
    """

    __slots__ = ("_target", "_path")

    def __init__(
        self,
        cloud: Union[PointCloud, np.ndarray, PathLike],
        *,
        normal_k: int = _DEFAULT_K,
        threads: int = 0,
    ) -> None:
        from ._register import _int32, _load_target  # the argument rules of register()

        handle, path = _load_target(cloud)
        if isinstance(handle, _core.TriangleMesh):
            self._target = _core.Target(handle, threads=_int32("threads", threads))
        else:
            self._target = _core.Target(
                handle, normal_k=_int32("normal_k", normal_k), threads=_int32("threads", threads)
            )
        self._path = path

    @property
    def path(self) -> str:
        """The file the target was read from ("" when built from memory)."""
        return self._path

    @property
    def normal_k(self) -> int:
        """Neighbours of the PCA normals it was prepared with."""
        return self._target.normal_k

    def __len__(self) -> int:
        return len(self._target)

    @property
    def is_mesh(self) -> bool:
        """True for a mesh target (its length is then the points of its surface sample)."""
        return self._target.is_mesh

    def __repr__(self) -> str:
        where = f" from {self._path!r}" if self._path else ""
        if self.is_mesh:
            return f"align3d.Target(a mesh{where})"
        return f"align3d.Target({len(self)} points{where}, normal_k={self.normal_k})"

    def __reduce__(self) -> Any:
        raise TypeError(
            "align3d.Target cannot be pickled: send the model's file name or array to the worker "
            "and prepare it there (align3d.batch does)"
        )
