"""find(): every instance of a part in a depth camera's scene (bin picking), with the settings of
``align3d find``, and its result."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import _core
from ._cloud import PathLike, PointCloud, matrix, rows
from ._errors import DataError
from ._mesh import TriangleMesh, is_mesh_file, read_mesh
from ._register import _Report, _is_path, _real, _text, _warn_all, _write_report

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
         image: Optional[PathLike] = None, method: str = _DEFAULTS["method"],
         kernel: str = _DEFAULTS["kernel"], kernel_scale: float = _DEFAULTS["kernel_scale"],
         strict: bool = False) -> FindResult:
    """Every instance of the part ``model`` in ``scene`` (``align3d find MODEL SCENE``).

    ``model``: a TriangleMesh, a PointCloud with outward normals, or a file (a mesh, a cloud, or a
    description saved by ``align3d.ppf_model(..., find=True)``, .ppf). ``scene``: a point cloud
    file; an organized PCD (a depth camera's image) is used as one. ``depth_range``: (min, max)
    along the camera axis. ``method``, ``kernel`` (``"auto"``: none here) and ``kernel_scale``:
    the ICP cost of each instance's final refinement, as :func:`register` takes them
    (``--method``, ``--kernel``, ``--kernel-scale``). ``report``, ``output`` (PLY) and ``image``
    (PNG) write what the command line writes. Raises what the command line reports (DataError naming the file, SettingsError);
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
                      image=os.fspath(image) if image else "", method=_text("method", method),
                      kernel=_text("kernel", kernel),
                      kernel_scale=_real("kernel_scale", kernel_scale))
    result = FindResult(json.loads(text))
    if report is not None:
        _write_report(report, text)
    if strict and result.warnings:
        from ._errors import StrictError
        raise StrictError("; ".join(w.message for w in result.warnings))
    _warn_all(result.warnings)
    return result


def match_instances(model_points: Any, found: Sequence[Any], truth: Sequence[Any],
                    visible: Sequence[float], max_error: float, *,
                    min_visible: float = 0.5) -> Dict[str, Any]:
    """BOP's scoring of found poses against the true ones (Hodaň et al. 2016, 2018), as the
    benchmark (bench/compare_find.py) and the tests score :func:`find`.

    ``model_points``: (N, 3) points of the model (its surface sampled evenly, e.g.
    ``read_mesh(f).sample(5000).points``); ``found``: 4x4 poses, best score first; ``truth``: the
    true 4x4 poses, and ``visible`` their visible fractions. Each found pose is matched to the not
    yet matched true pose of lowest ADD-S (the mean distance from each model point, posed, to the
    nearest point of the model at the other pose: a symmetric part turned about its axis has no
    error), if below ``max_error`` (in the points' units; BOP uses 10 % of the model's diameter).
    True instances less visible than ``min_visible`` do not count for recall, and a pose matched
    to one is ``excused`` (neither a true nor a false positive).

    Returns a dict: ``counted``, ``true_positives``, ``false_positives``, ``excused``, ``match``
    (per found pose: the index of its true pose, or -1), ``error`` (per found pose: ADD-S to its
    match, or to the nearest true pose when unmatched; inf with none), ``recall`` and
    ``precision`` (1 when there is nothing to count).
    """
    points = rows("model_points", model_points)
    if points.shape[0] == 0:
        raise ValueError("model_points: no points")
    if not np.isfinite(points).all():
        raise DataError("model_points: a point is not finite (NaN or Inf)")
    found_m = [matrix(f"found[{k}]", T) for k, T in enumerate(found)]
    truth_m = [matrix(f"truth[{k}]", T) for k, T in enumerate(truth)]
    fractions = [float(v) for v in visible]
    if len(fractions) != len(truth_m):
        raise ValueError(f"visible: {len(fractions)} fractions for {len(truth_m)} true poses")
    if not (np.isfinite(max_error) and max_error > 0):
        raise ValueError(f"max_error: expected a positive distance, got {max_error}")
    if not 0 <= min_visible <= 1:
        raise ValueError(f"min_visible: expected a fraction in [0, 1], got {min_visible}")
    return _core.match_instances(points, found_m, truth_m, fractions, float(max_error),
                                 float(min_visible))
