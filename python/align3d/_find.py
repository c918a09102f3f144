"""find(): every instance of a part in a depth camera's scene (bin picking), with the settings of
``align3d find``, and its result."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import _core
from ._cloud import PathLike, PointCloud
from ._mesh import TriangleMesh, is_mesh_file, read_mesh
from ._register import _Report, _is_path, _warn_all, _write_report

_DEFAULTS = _core.find_defaults()


class FindResult(_Report):
    """The result of :func:`find`: the instances found, best score first. Attributes read the
    report :meth:`to_dict` returns (the command line's ``--report``, docs/report.md, "find")."""

    __slots__ = ()

    @property
    def instances(self) -> List[Dict[str, Any]]:
        """One dict per instance, best first: ``transformation`` (4x4 array, MODEL -> SCENE),
        ``score``, ``visible_fraction``, ``rms``, ``points``, ``symmetry``."""
        out = []
        for i in self._report["instances"]:
            d = dict(i)
            d["transformation"] = np.array(i["transformation"], dtype=np.float64)
            out.append(d)
        return out

    @property
    def transformation(self) -> np.ndarray:  # type: ignore[override]
        raise AttributeError("a find result has one transformation per instance: .instances")


def find(model: Any, scene: PathLike, *, max_instances: int = 0,
         min_score: float = _DEFAULTS["min_score"], symmetry: str = "auto",
         voxel_fraction: float = _DEFAULTS["voxel_fraction"], keep_plane: bool = False,
         depth_range: Optional[Sequence[float]] = None, seed: int = 1, threads: int = 0,
         report: Optional[PathLike] = None, output: Optional[PathLike] = None,
         image: Optional[PathLike] = None, strict: bool = False) -> FindResult:
    """Every instance of the part ``model`` in ``scene`` (``align3d find MODEL SCENE``).

    ``model``: a TriangleMesh, a PointCloud with outward normals, or a file (a mesh, a cloud, or a
    description saved by ``align3d.ppf_model(..., find=True)``, .ppf). ``scene``: a point cloud
    file; an organized PCD (a depth camera's image) is used as one. ``depth_range``: (min, max)
    along the camera axis. ``report``, ``output`` (PLY) and ``image`` (PNG) write what the command
    line writes. Raises what the command line reports (DataError naming the file, SettingsError);
    with ``strict``, warnings raise StrictError."""
    lo, hi = (0.0, float("inf")) if depth_range is None else (float(depth_range[0]),
                                                              float(depth_range[1]))
    if not (0 <= lo < hi):
        from ._errors import SettingsError
        raise SettingsError(f"depth_range: expected (min, max) with 0 <= min < max, "
                            f"got {depth_range!r}")
    model_path = ""
    if _is_path(model):
        model_path = os.fspath(model)
        if model_path.endswith(".ppf"):
            model_data: Any = model_path
        elif is_mesh_file(model_path):
            model_data = read_mesh(model_path)._mesh
        else:
            from ._cloud import read_point_cloud
            model_data = read_point_cloud(model_path)._cloud
    elif isinstance(model, TriangleMesh):
        model_data = model._mesh
    elif isinstance(model, PointCloud):
        model_data = model._cloud
    else:
        raise TypeError(f"model: expected a TriangleMesh, a PointCloud or a file name, "
                        f"got {type(model).__name__}")
    text = _core.find(model_data, max_instances=int(max_instances), min_score=float(min_score),
                      voxel_fraction=float(voxel_fraction), min_depth=lo, max_depth=hi,
                      symmetry=str(symmetry), keep_plane=bool(keep_plane), seed=int(seed),
                      threads=int(threads), model_path=model_path, scene_path=os.fspath(scene),
                      output=os.fspath(output) if output else "",
                      image=os.fspath(image) if image else "")
    result = FindResult(json.loads(text))
    if report is not None:
        _write_report(report, text)
    if strict and result.warnings:
        from ._errors import StrictError
        raise StrictError("; ".join(w.message for w in result.warnings))
    _warn_all(result.warnings)
    return result
