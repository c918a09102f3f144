"""register() and rectify(): the library's align() and rectify() with the settings of
``align3d register`` and ``align3d rectify``, and their results."""

from __future__ import annotations

import copy
import json
import numbers
import operator
import os
import sys
import time
import warnings
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _core
from ._cloud import PathLike, PointCloud, as_cloud, matrix, read_point_cloud, write_point_cloud
from ._target import Target
from ._errors import AlignWarning, DataError, NoSolutionError, SettingsError, StrictError

_REGISTER = _core.defaults()["register"]
_RECTIFY = _core.defaults()["rectify"]
_INIT_POLICIES = ("auto", "identity", "global")

Progress = Callable[[str, int, int], Any]


def _is_path(value: Any) -> bool:
    return isinstance(value, (str, os.PathLike))


def _integer(name: str, value: Any, low: int, high: int) -> int:
    """An integer in [low, high]: TypeError for another type, SettingsError outside the C++
    type's range (the library checks the meaningful range)."""
    if isinstance(value, bool):
        raise TypeError(f"{name}: expected an integer, got a bool")
    try:
        v = operator.index(value)
    except TypeError:
        raise TypeError(f"{name}: expected an integer, got {type(value).__name__}") from None
    if not low <= v <= high:
        raise SettingsError(f"{name}: {v} is out of range [{low}, {high}]")
    return v


def _int32(name: str, value: Any) -> int:
    return _integer(name, value, -(2**31), 2**31 - 1)


def _seed(value: Any) -> int:
    return _integer("seed", value, 0, 2**64 - 1)


def _real(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a number, got {type(value).__name__}")
    return float(value)


def _text(name: str, value: Any) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected a string, got {type(value).__name__}")
    return value


def _load(role: str, value: Any) -> Tuple[PointCloud, str]:
    """The cloud of a source or target argument and the path the report shows ("" in memory)."""
    if _is_path(value):
        return read_point_cloud(value), os.fspath(value)
    return as_cloud(value), ""


def _load_target(value: Any) -> Tuple[Any, str]:
    """A target as _core takes it: a mesh (a TriangleMesh, or a file align3d reads as a mesh:
    its exact surface is registered onto) or a cloud, with the path reports show."""
    from ._mesh import TriangleMesh, is_mesh_file, read_mesh

    if isinstance(value, TriangleMesh):
        return value._mesh, ""
    if _is_path(value) and is_mesh_file(value):
        return read_mesh(value)._mesh, os.fspath(value)
    cloud, path = _load("target", value)
    return cloud._cloud, path


def _pose(name: str, value: Any) -> Union[str, np.ndarray]:
    """A transform file's name (the extension reads it as the command line does, bit for bit),
    or a checked 4x4 array."""
    return os.fspath(value) if _is_path(value) else matrix(name, value)


def _naming_file(e: DataError, files: Dict[str, Tuple[str, str]]) -> Optional[DataError]:
    """``e``, a DataError from the extension, re-made to name its file as the command line does
    ("scan.ply (source): ..."): ``files`` maps ``e.subject`` ("source", "target") to (the path
    given, the role to show). None when the subject is neither or its path is empty (data in
    memory): the caller then re-raises ``e`` as it is."""
    path, role = files.get(e.subject, ("", ""))
    if not path:
        return None
    error = DataError(f"{path} ({role}): {e.problem}")
    error.subject, error.problem = f"{path} ({role})", e.problem
    return error


def _warn_all(found: List[AlignWarning]) -> None:
    for w in found:
        warnings.warn(w, stacklevel=3)


def _write_report(path: PathLike, text: str) -> None:
    if os.fspath(path) == "-":
        sys.stdout.write(text)
        sys.stdout.flush()
    else:
        _core.write_text(os.fspath(path), text)


class _Report:
    """A result backed by its JSON report (docs/report.md): every attribute reads it."""

    __slots__ = ("_report",)

    def __init__(self, report: Dict[str, Any]) -> None:
        self._report = report

    def to_dict(self) -> Dict[str, Any]:
        """The JSON report, key for key what the command line writes with ``--report``
        (docs/report.md), as a new dict (built by the same C++ function,
        ``report::registration_report`` / ``report::rectify_report``). Numbers that are not
        finite (an unbounded threshold) are None, as JSON's null."""
        return copy.deepcopy(self._report)

    @property
    def transformation(self) -> np.ndarray:
        """4x4 float64 array, row-major (a new array each time)."""
        return np.array(self._report["transformation"], dtype=np.float64)

    @property
    def warnings(self) -> List[AlignWarning]:
        """What may be wrong with the result (empty when clean; docs/report.md has the codes)."""
        return [AlignWarning(w["code"], w["message"]) for w in self._report["warnings"]]


class Result(_Report):
    """The result of :func:`register`: T with **target ≈ T·source** and how it was found.

    Every attribute reads the report :meth:`to_dict` returns (keys and units: docs/report.md,
    "align3d register"); distances are in the data's units.
    """

    __slots__ = ()

    @property
    def success(self) -> bool:
        """Always True for a returned result (no solution raises :class:`NoSolutionError`)."""
        return bool(self._report["success"])

    @property
    def failure(self) -> Optional[str]:
        """Why there is no solution (only on NoSolutionError's result), else None."""
        return self._report.get("failure")

    @property
    def rms(self) -> float:
        """RMS residual of the kept pairs at the final pose: distance (point-to-point: to the
        nearest target point, or with ``auto`` onto a point cloud to that point's tangent plane)
        or distance to the tangent plane (the other methods), data units."""
        return self._report["rms"]

    @property
    def covariance(self) -> np.ndarray:
        """6x6 float64 covariance of ``transformation``: rotation (radians) then translation, for
        T ← exp(ξ)·T about the target frame's origin (docs/report.md, ``covariance``: the noise,
        point-to-plane's model error, the step ICP did not take). The accuracy of a correct
        convergence only; a wrong minimum is flagged by the warnings."""
        return np.array(self._report["covariance"], dtype=np.float64)

    @property
    def pending_sigmas(self) -> float:
        """The length of ICP's next update in standard deviations of ``covariance`` (without that
        update's own term): far below 1 at a stationary point, above 2 warned as
        ``stopped_short`` (docs/report.md)."""
        return float(self._report["pending_sigmas"])

    @property
    def fitness(self) -> float:
        """Kept pairs ÷ points of the moving cloud (Open3D's meaning; not an accuracy)."""
        return self._report["fitness"]

    @property
    def correspondences(self) -> int:
        """Kept pairs at the final pose."""
        return self._report["correspondences"]

    @property
    def converged(self) -> bool:
        """A convergence criterion fired with enough pairs (never merely the iteration cap)."""
        return self._report["converged"]

    @property
    def stop_reason(self) -> str:
        """``rms_change``, ``transform_change``, ``cycle``, ``max_iterations`` or
        ``too_few_correspondences``."""
        return self._report["stop_reason"]

    @property
    def iterations(self) -> int:
        """ICP updates over all stages."""
        return self._report["iterations"]

    @property
    def history(self) -> List[Dict[str, Any]]:
        """One dict per evaluated pose: ``rms``, ``kept``, ``threshold`` (None when unbounded)."""
        return copy.deepcopy(self._report["history"])

    @property
    def stages(self) -> List[Dict[str, Any]]:
        """The ICP runs: ``metric``, ``max_distance``, ``first_iteration``, ``iterations``."""
        return copy.deepcopy(self._report["stages"])

    @property
    def rotation_deg(self) -> float:
        """Angle of T's rotation, degrees."""
        return self._report["rotation_deg"]

    @property
    def translation(self) -> np.ndarray:
        """T's translation (3 floats, data units)."""
        return np.array(self._report["translation"], dtype=np.float64)

    @property
    def support(self) -> Dict[str, Any]:
        """How well the data support the answer: ``overlap`` (share of the object's points on the
        other cloud's surface), ``object``, ``noise``, ``spacing``, ``reach``, ``band``."""
        return copy.deepcopy(self._report["support"])

    @property
    def init(self) -> Dict[str, Any]:
        """How the answer was found: ``policy``, ``path`` (the answer kept), ``reason`` (why the
        global stage ran), ``candidates`` (every answer considered)."""
        return copy.deepcopy(self._report["init"])

    @property
    def global_stage(self) -> Optional[Dict[str, Any]]:
        """The global stage's diagnostics (the report's ``global``: ``method``, ``success``,
        ``voxel``, ``score``, ``overlap``, ``candidates``, ``transformation``, ``ambiguous``,
        ``message``, ``time_ms``, ...), or None when it did not run."""
        g = self._report.get("global")
        return copy.deepcopy(g) if g is not None else None

    @property
    def icp_direction(self) -> str:
        """``source onto target``, or ``target onto source`` (a part in a wide scene)."""
        return self._report["icp_direction"]

    @property
    def degenerate_directions(self) -> List[Dict[str, Any]]:
        """Directions the geometry leaves free at the final pose, weakest first."""
        return copy.deepcopy(self._report["degenerate_directions"])

    @property
    def rotation_error_deg(self) -> Optional[float]:
        """With ``ground_truth``: angle of R_estᵀ·R_true (degrees); else None."""
        return self._report.get("rotation_error_deg")

    @property
    def translation_error(self) -> Optional[float]:
        """With ``ground_truth``: ‖t_est − t_true‖ (data units); else None."""
        return self._report.get("translation_error")

    @property
    def timing_ms(self) -> Dict[str, float]:
        """``total``, ``global``, ``refine``, ``support``, ``read`` (files read here), ms."""
        return dict(self._report["timing_ms"])

    def __repr__(self) -> str:
        return (
            f"<align3d.Result rms={self.rms:.6g} fitness={self.fitness:.4g} "
            f"converged={self.converged} ({self.stop_reason}), {self.iterations} iterations, "
            f"rotation {self.rotation_deg:.4g} deg, path {self.init['path']!r}, "
            f"{len(self._report['warnings'])} warning(s)>"
        )


class RectifyResult(_Report):
    """The result of :func:`rectify`: the transform that levels the cloud (cloud → levelled frame:
    the plane's normal on +Z, the plane on z = 0). Attributes read the report :meth:`to_dict`
    returns (docs/report.md, "align3d rectify")."""

    __slots__ = ()

    @property
    def normal(self) -> np.ndarray:
        """The fitted plane's unit normal, oriented up, in the cloud's frame."""
        return np.array(self._report["normal"], dtype=np.float64)

    @property
    def tilt_before_deg(self) -> float:
        """Angle between the normal and +Z, degrees."""
        return self._report["tilt_before_deg"]

    @property
    def tilt_after_deg(self) -> float:
        """The same, measured again on the levelled inliers."""
        return self._report["tilt_after_deg"]

    @property
    def inliers(self) -> int:
        """Points the plane was fitted to."""
        return self._report["inliers"]

    @property
    def flatness(self) -> float:
        """Peak-to-valley of the inliers' distances to the plane (data units)."""
        return self._report["flatness"]

    @property
    def rms(self) -> float:
        """RMS of those distances (data units)."""
        return self._report["rms"]

    @property
    def noise(self) -> float:
        """The cloud's surface noise, to compare ``rms`` with (data units)."""
        return self._report["noise"]

    @property
    def fit(self) -> str:
        """``robust`` or ``lsq``."""
        return self._report["fit"]

    def __repr__(self) -> str:
        return (
            f"<align3d.RectifyResult tilt {self.tilt_before_deg:.4g} -> "
            f"{self.tilt_after_deg:.3g} deg, {self.inliers} inliers, rms {self.rms:.4g}, "
            f"{len(self._report['warnings'])} warning(s)>"
        )


def register(
    source: Union[PointCloud, np.ndarray, PathLike],
    target: Union[PointCloud, np.ndarray, PathLike, "Target"],
    *,
    init: Union[str, np.ndarray, PathLike] = _REGISTER["init"],
    method: str = _REGISTER["method"],
    kernel: str = _REGISTER["kernel"],
    kernel_scale: float = _REGISTER["kernel_scale"],
    global_method: str = _REGISTER["global_method"],
    ppf_model: Optional[PathLike] = None,
    voxel: float = _REGISTER["voxel"],
    seed: int = _REGISTER["seed"],
    mutual: bool = _REGISTER["mutual"],
    reject: str = _REGISTER["reject"],
    max_iterations: int = _REGISTER["max_iterations"],
    tolerance: float = _REGISTER["tolerance"],
    normal_k: Optional[int] = None,
    model_error: bool = _REGISTER["model_error"],
    threads: int = _REGISTER["threads"],
    ground_truth: Optional[Union[np.ndarray, PathLike]] = None,
    output: Optional[PathLike] = None,
    report: Optional[PathLike] = None,
    strict: bool = False,
    progress: Optional[Progress] = None,
) -> Result:
    """Registers SOURCE onto TARGET: finds the rigid T with **target ≈ T·source** (``align3d
    register``; the library's ``align()``).

    SOURCE is the measured scan, moved; TARGET the fixed reference (the model). Each is a
    :class:`PointCloud`, an (N, 3) array, or a file name (read as :func:`read_point_cloud` does;
    the report then shows the path, as the command line's does); TARGET may also be a
    :class:`TriangleMesh` or a mesh file (a CAD model: the scan is registered onto its exact
    surface), or a :class:`Target`, prepared once for many sources (the same pose, less work per
    call).

    Units and convention: distances are in the data's units (mm, m, ...) and every default
    distance follows the data (the object's extent, the target's point spacing, the noise), so
    the same clouds in mm or in m give the same pose. ``Result.transformation`` is a 4x4 array,
    row-major, mapping source coordinates into the target's frame: ``target ≈ T @ [x, y, z, 1]``.

    Keywords are the flags of ``align3d register`` (``--max-iterations`` is ``max_iterations``;
    ``--global`` is ``global_method``, ``global`` being a Python keyword); defaults are the
    library's:

    - ``init``: ``"auto"`` (ICP from the identity; when that answer is not well supported, the
      global stage runs too and the better supported answer is kept, and when that does not
      help, ICP from the identity again with basin hopping), ``"identity"``,
      ``"global"`` (global registration first: any starting pose), or the initial pose: a 4x4
      array or a transform file (ICP starts there).
    - ``method``: the final ICP metric, ``"point-to-plane"``, ``"point-to-point"``, ``"gicp"``
      (plane-to-plane with per-point covariances, as small_gicp) or ``"symmetric"``
      (Rusinkiewicz 2019); with ``reject="auto"`` the coarse stages are point-to-plane whatever
      the method. gicp and symmetric need SOURCE's normals: estimated when it has none.
    - ``kernel``: the robust kernel weighing ICP's pairs, ``"auto"`` (the schedule's own),
      ``"none"``, ``"huber"``, ``"cauchy"``, ``"geman-mcclure"``, ``"tukey"`` or ``"welsch"``;
      ``kernel_scale``: its scale (data units; 0: from the noise).
    - ``global_method``: ``"fpfh"`` (descriptors + RANSAC) or ``"ppf"`` (point pair features);
      ``ppf_model``: a file saved by :func:`ppf_model` describing TARGET (implies ppf).
    - ``voxel``: voxel of the global stage (data units; 0: from the smaller cloud's extent).
    - ``seed``: seed of the global stage (same seed, same pose). ``mutual``: fpfh keeps only
      mutual descriptor nearest neighbours.
    - ``reject``: ``"auto"`` (coarse-to-fine schedule scaled to the data), ``"median[:F[:FLOOR]]"``,
      ``"distance:D"`` (data units) or ``"none"``.
    - ``max_iterations``: ICP's cap (of the final stage with ``reject="auto"``);
      ``tolerance``: stop when |ΔRMS| < tolerance·RMS (relative, unit-free).
    - ``normal_k``: neighbours of the target's PCA normals (default 20, or a :class:`Target`'s
      own). ``threads``: 0 uses every core; the
      result does not depend on it.
    - ``model_error``: the covariance also takes in point-to-plane's (and point-to-point's) model
      error, the bias of a tangent plane on a curved surface (it needs SOURCE's normals: about a
      third more time on two 40 000-point scans).
    - ``ground_truth``: the true T (4x4 array or file); adds ``rotation_error_deg`` and
      ``translation_error``.
    - ``output``: write SOURCE moved into TARGET's frame; ``report``: write the JSON report (``-``:
      stdout); ``strict``: raise :class:`StrictError` when the result comes with warnings
      (outputs are written first).
    - ``progress``: called as ``progress(task, done, total)`` between stages, on the calling
      thread (an exception it raises is re-raised when the registration ends).

    Warnings (docs/report.md) are in ``Result.warnings`` and issued as :class:`AlignWarning`
    (``warnings.simplefilter("error", align3d.AlignWarning)`` also makes them errors).

    Raises :class:`FileError` (a file), :class:`DataError` (clouds that cannot be registered: too
    few points, all on a line, NaN), :class:`SettingsError` (a keyword no run can use),
    :class:`NoSolutionError` (too few correspondences; its ``result`` has the report),
    ``ValueError`` for an array of the wrong shape or dtype and ``TypeError`` for a keyword of the
    wrong type. The GIL is released while the clouds are read and registered: Python threads
    register in parallel.
    """
    settings = dict(
        method=_text("method", method),
        kernel=_text("kernel", kernel),
        kernel_scale=_real("kernel_scale", kernel_scale),
        global_method=_text("global_method", global_method),
        voxel=_real("voxel", voxel),
        seed=_seed(seed),
        mutual=bool(mutual),
        reject=_text("reject", reject),
        max_iterations=_int32("max_iterations", max_iterations),
        tolerance=_real("tolerance", tolerance),
        normal_k=_int32(
            "normal_k",
            normal_k
            if normal_k is not None
            else (target.normal_k if isinstance(target, Target) else _REGISTER["normal_k"]),
        ),
        model_error=bool(model_error),
        threads=_int32("threads", threads),
    )
    if progress is not None and not callable(progress):
        raise TypeError("progress: expected a callable progress(task, done, total)")
    start = time.perf_counter()
    source_cloud, source_path = _load("source", source)
    if isinstance(target, Target):
        target_handle, target_path = target._target, target.path
    else:
        target_handle, target_path = _load_target(target)
    initial_pose = None
    if isinstance(init, str) and init in _INIT_POLICIES:
        policy = init
    else:  # a pose: a 4x4 array, or a file as `--init FILE`
        policy = "pose"
        initial_pose = _pose("init", init)
    truth = None if ground_truth is None else _pose("ground_truth", ground_truth)
    read_ms = (time.perf_counter() - start) * 1e3 if source_path or target_path else 0.0
    try:
        text = _core.register(
            source_cloud._cloud,
            target_handle,
            init=policy,
            initial_pose=initial_pose,
            ppf_model=None if ppf_model is None else os.fspath(ppf_model),
            ground_truth=truth,
            source_path=source_path,
            target_path=target_path,
            read_ms=read_ms,
            progress=progress,
            **settings,
        )
    except DataError as e:  # name the file, as the command line does
        named = _naming_file(e, {"source": (source_path, "source"),
                                 "target": (target_path, "target")})
        if named is None:
            raise
        raise named from None
    result = Result(json.loads(text))
    if report is not None:
        _write_report(report, text)
    found = result.warnings
    if not result.success:
        _warn_all(found)
        raise NoSolutionError(
            f"{source_path or 'source'}: no solution: {result.failure}", result
        )
    if output is not None:
        write_point_cloud(output, source_cloud.transformed(result.transformation))
    _warn_all(found)
    if strict and found:
        raise StrictError(
            f"{len(found)} warning(s): " + "; ".join(w.code for w in found), result
        )
    return result


def rectify(
    cloud: Union[PointCloud, np.ndarray, PathLike],
    *,
    fit: str = _RECTIFY["fit"],
    up: Optional[Any] = None,
    seed: int = _RECTIFY["seed"],
    output: Optional[PathLike] = None,
    report: Optional[PathLike] = None,
    strict: bool = False,
) -> RectifyResult:
    """Levels a cloud (``align3d rectify``; chapter 39.5): fits its plane, rotates the normal onto
    +Z and shifts the plane to z = 0. ``RectifyResult.transformation`` maps the cloud into the
    levelled frame (4x4, row-major); distances are in the data's units.

    ``cloud``: a :class:`PointCloud`, an (N, 3) array or a file name. ``fit``: ``"robust"`` (the
    dominant plane: RANSAC, then least squares on its inliers; right with parts, walls, clutter)
    or ``"lsq"`` (least squares on every point: the chapter's fit, for the plate alone). ``up``:
    the direction that counts as up (3 numbers; default: the side a part on the plane stands on,
    else +Z). ``seed``: RANSAC's seed. ``output``: write the levelled cloud; ``report``: the JSON
    report (``-``: stdout); ``strict``: raise :class:`StrictError` when the result comes with
    warnings (``not_flat``: the fitted points do not lie on one plane).

    Raises :class:`DataError` when the cloud defines no plane, :class:`FileError`,
    :class:`SettingsError`, ``ValueError``/``TypeError`` as :func:`register`.
    """
    fit = _text("fit", fit)
    seed = _seed(seed)
    up_vector = None
    if up is not None:
        up_vector = np.asarray(up)
        if up_vector.dtype.kind not in "fiu" or up_vector.shape != (3,):
            raise ValueError(f"up: expected 3 numbers, got {up!r}")
        up_vector = up_vector.astype(np.float64)
    c, path = _load("cloud", cloud)
    try:
        text = _core.rectify(c._cloud, fit=fit, up=up_vector, seed=seed, cloud_path=path)
    except DataError as e:  # which file has no plane, as the command line says
        if not path:
            raise
        error = DataError(f"{path}: {e}")
        error.subject, error.problem = path, str(e)
        raise error from None
    result = RectifyResult(json.loads(text))
    if output is not None:
        write_point_cloud(output, c.transformed(result.transformation))
    if report is not None:
        _write_report(report, text)
    found = result.warnings
    _warn_all(found)
    if strict and found:
        raise StrictError(
            f"{len(found)} warning(s): " + "; ".join(w.code for w in found), result
        )
    return result
