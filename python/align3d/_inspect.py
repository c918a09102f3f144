"""inspect(): the library's inspection of a measured part against its CAD model, with the settings
of ``align3d inspect``, and its result."""

from __future__ import annotations

import json
import numbers
import os
import time
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from ._cloud import PathLike, PointCloud
from ._errors import DataError, NoSolutionError, SettingsError, StrictError
from ._mesh import TriangleMesh, read_mesh
from ._register import _Report, _int32, _is_path, _load, _naming_file, _pose, _real, _seed, \
    _text, _warn_all, _write_report
from ._target import Target

_DEFAULTS = _core.inspect_defaults()

Tolerance = Union[float, Sequence[float]]


def _band(tolerance: Tolerance) -> Tuple[float, float]:
    """T (the band ±T) or (lower, upper) with lower <= 0 <= upper and lower < upper."""
    if isinstance(tolerance, numbers.Real) and not isinstance(tolerance, bool):
        t = float(tolerance)
        if not (np.isfinite(t) and t > 0):
            raise SettingsError(f"tolerance: a symmetric tolerance must be a finite number > 0, "
                                f"got {tolerance!r}")
        return -t, t
    try:
        lower, upper = (_real("tolerance", v) for v in tolerance)
    except (TypeError, ValueError):
        raise TypeError("tolerance: expected T (the band ±T) or (lower, upper)") from None
    if not (np.isfinite(lower) and np.isfinite(upper) and lower <= 0 <= upper and lower < upper):
        raise SettingsError(f"tolerance: the band must hold 0 and be wide, got ({lower}, {upper})")
    return lower, upper


def _cad(value: Any, chord_tolerance: float) -> Tuple[Any, str]:
    """The CAD argument as _core takes it (a mesh or a prepared mesh) and the path reports show."""
    if isinstance(value, Target):
        if not value._target.is_mesh:
            raise TypeError("cad: a Target of a point cloud; inspection needs a mesh")
        return value._target, value.path
    if isinstance(value, TriangleMesh):
        return value._mesh, ""
    if _is_path(value):
        return read_mesh(value, chord_tolerance=chord_tolerance)._mesh, os.fspath(value)
    raise TypeError(f"cad: expected a TriangleMesh, a Target of one or a file name, "
                    f"got {type(value).__name__}")


class InspectResult(_Report):
    """The result of :func:`inspect`: the scan's pose in the CAD frame, every point's signed
    deviation from the CAD surface and the verdict. Attributes read the report :meth:`to_dict`
    returns (the command line's ``--report``, docs/report.md, "align3d inspect"), except the
    per-point arrays."""

    __slots__ = ("_deviations", "_closest", "_triangles")

    def __init__(self, report: Dict[str, Any], deviations: np.ndarray, closest: np.ndarray,
                 triangles: np.ndarray) -> None:
        super().__init__(report)
        for a in (deviations, closest, triangles):
            a.setflags(write=False)
        self._deviations, self._closest, self._triangles = deviations, closest, triangles

    @property
    def deviations(self) -> np.ndarray:
        """(N,) float64, per scan point in its order: the signed distance to the CAD surface
        (+ outside the material), NaN for outliers (farther than ``max_distance``)."""
        return self._deviations

    @property
    def closest_points(self) -> np.ndarray:
        """(N, 3) float64: each point's closest point on the CAD surface (CAD frame; NaN for
        outliers)."""
        return self._closest

    @property
    def triangles(self) -> np.ndarray:
        """(N,) int64: the triangle of each closest point, in the cleaned mesh's numbering
        (``TriangleMesh.cleaned()``); −1 for outliers."""
        return self._triangles

    @property
    def verdict(self) -> str:
        """``"pass"`` or ``"fail"``."""
        return self._report["verdict"]

    @property
    def passed(self) -> bool:
        """True when the verdict is ``"pass"``."""
        return self._report["verdict"] == "pass"

    @property
    def within_tolerance(self) -> float:
        """Share of the measured points (outliers left out) inside the band."""
        return self._report["within_tolerance"]

    @property
    def outliers(self) -> int:
        """Scan points farther than ``max_distance`` from every surface: left out of the
        statistics, NaN in :attr:`deviations`."""
        return self._report["outliers"]

    @property
    def tolerance(self) -> Tuple[float, float]:
        """The band (lower, upper) around 0, in the data's units."""
        t = self._report["tolerance"]
        return t["lower"], t["upper"]

    @property
    def stats(self) -> Dict[str, float]:
        """``count``, ``mean``, ``std``, ``rms``, ``min``, ``max``, ``p01`` … ``p99``."""
        return dict(self._report["deviation"])

    @property
    def gauss_fit(self) -> Dict[str, float]:
        """``mean`` (the median) and ``sigma`` (1.4826 × the median absolute deviation)."""
        return dict(self._report["gauss_fit"])

    def __repr__(self) -> str:
        s = self._report["deviation"]
        return (
            f"<align3d.InspectResult {self.verdict.upper()}: {100 * self.within_tolerance:.2f} % "
            f"of {s['count']} points within {self.tolerance}, {self.outliers} outliers, "
            f"deviation {s['min']:.4g} .. {s['max']:.4g}, "
            f"{len(self._report['warnings'])} warning(s)>"
        )


def inspect(
    scan: Union[PointCloud, np.ndarray, PathLike],
    cad: Union[TriangleMesh, Target, PathLike],
    *,
    tolerance: Tolerance,
    init: Union[str, np.ndarray, PathLike] = _DEFAULTS["init"],
    method: str = _DEFAULTS["method"],
    kernel: str = _DEFAULTS["kernel"],
    kernel_scale: float = _DEFAULTS["kernel_scale"],
    max_distance: float = _DEFAULTS["max_distance"],
    pass_fraction: float = _DEFAULTS["pass_fraction"],
    seed: int = _DEFAULTS["seed"],
    threads: int = _DEFAULTS["threads"],
    chord_tolerance: float = 0.0,
    output: Optional[PathLike] = None,
    csv: Optional[PathLike] = None,
    histogram: Optional[PathLike] = None,
    html: Optional[PathLike] = None,
    figures: Optional[PathLike] = None,
    units: str = "",
    report: Optional[PathLike] = None,
    strict: bool = False,
) -> InspectResult:
    """Inspects a measured part against its CAD model (``align3d inspect``): registers ``scan``
    onto the exact surface of ``cad`` (a best fit that local dents and bumps do not pull), then
    measures every scan point's signed deviation (+ outside the material) and judges it against
    ``tolerance``.

    ``scan``: a :class:`PointCloud`, an (N, 3) array or a file name. ``cad``: a
    :class:`TriangleMesh`, a :class:`Target` of one (prepared once for many scans) or a mesh file
    (STEP/IGES tessellated to ``chord_tolerance``). ``tolerance``: T for the band ±T, or
    ``(lower, upper)`` (lower <= 0 <= upper), in the data's units. Keywords are the command's
    flags: ``init`` (``"auto"``, ``"identity"``, ``"global"`` or a 4x4 pose, scan → CAD),
    ``method``, ``kernel`` and ``kernel_scale`` (the ICP metric and robust kernel, as
    :func:`register`),
    ``max_distance`` (points farther from every surface are outliers; 0: the larger of 5 × the
    band's larger half and 1 % of the CAD's diagonal), ``pass_fraction`` (the part passes when
    at least this share of the measured points is in the band), ``seed``, ``threads``;
    ``output`` (the coloured deviation PLY), ``csv`` (per-point deviations and closest points),
    ``histogram`` (CSV), ``html`` (the offline page; ``units`` labels it), ``figures`` (a folder
    for ``views.png`` and ``histogram.png``/``.svg``), ``report`` (JSON;
    ``-``: stdout), ``strict`` (raise :class:`StrictError` on warnings, after the files).

    A part out of tolerance is not an error: ``InspectResult.verdict`` is ``"fail"``. Raises
    :class:`FileError`, :class:`DataError` (a scan or mesh that cannot be measured),
    :class:`SettingsError`, :class:`NoSolutionError` (no registration) and
    ``ValueError``/``TypeError`` for arrays or keywords of the wrong kind. The GIL is released
    while the library works.
    """
    lower, upper = _band(tolerance)
    start = time.perf_counter()
    cloud, scan_path = _load("scan", scan)
    handle, cad_path = _cad(cad, _real("chord_tolerance", chord_tolerance))
    initial_pose = None
    if isinstance(init, str) and init in ("auto", "identity", "global"):
        policy = init
    else:
        policy, initial_pose = "pose", _pose("init", init)
        if isinstance(initial_pose, str):
            initial_pose = np.asarray(_core.read_matrix(initial_pose))
    read_ms = (time.perf_counter() - start) * 1e3 if scan_path or cad_path else 0.0
    files = {k: "" if v is None else os.fspath(v)
             for k, v in dict(output=output, csv=csv, histogram=histogram, html=html,
                              figures=figures).items()}
    try:
        text, deviations, closest, triangles = _core.inspect(
            cloud._cloud, handle, lower=lower, upper=upper,
            max_distance=_real("max_distance", max_distance),
            pass_fraction=_real("pass_fraction", pass_fraction), init=policy,
            initial_pose=initial_pose, method=_text("method", method),
            kernel=_text("kernel", kernel), kernel_scale=_real("kernel_scale", kernel_scale),
            seed=_seed(seed), threads=_int32("threads", threads),
            scan_path=scan_path, cad_path=cad_path, read_ms=read_ms, units=str(units), **files)
    except DataError as e:  # name the file, as the command line does
        named = _naming_file(e, {"source": (scan_path, "scan"), "target": (cad_path, "CAD")})
        if named is None:
            raise
        raise named from None
    result = InspectResult(json.loads(text), deviations, closest, triangles)
    if report is not None:
        _write_report(report, text)
    found = result.warnings
    _warn_all(found)
    if not result._report["success"]:
        raise NoSolutionError(f"{scan_path or 'scan'}: no solution: {result._report['failure']}",
                              result)
    if strict and found:
        raise StrictError(f"{len(found)} warning(s): " + "; ".join(w.code for w in found), result)
    return result
