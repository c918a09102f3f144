"""stitch(): many scans of one object into the frame of the first, as one surface, with the
settings of ``align3d stitch``, and its result."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import _core
from ._cloud import PathLike, PointCloud, _read, rows
from ._errors import DataError, StrictError
from ._register import (_Report, _int32, _is_path, _real, _text, _warn_all,
                        _write_report)

_DEFAULTS = _core.stitch_defaults()


class StitchResult(_Report):
    """The result of :func:`stitch`: each scan's pose in the first scan's frame
    (**scan_0 ≈ T·scan_k**), the overlapping pairs found and the merged cloud. Attributes read the
    report :meth:`to_dict` returns (the command line's ``--report``, docs/report.md, "stitch"),
    except the merged cloud and its scan indices."""

    __slots__ = ("_merged", "_merged_scan")

    def __init__(self, report: Dict[str, Any], merged: PointCloud,
                 merged_scan: np.ndarray) -> None:
        super().__init__(report)
        merged_scan.setflags(write=False)
        self._merged, self._merged_scan = merged, merged_scan

    def __repr__(self) -> str:
        n, connected = len(self.connected), sum(self.connected)
        return (f"<align3d.StitchResult of {n} scans, {connected} connected, "
                f"{len(self._merged)} merged points, {len(self.warnings)} warning(s)>")

    @property
    def poses(self) -> List[np.ndarray]:
        """Per scan in input order, the 4x4 float64 pose mapping it into the first scan's frame
        (scan_0 ≈ T·scan_k; the first is the identity). A scan that is not connected keeps a pose
        no edge supports: check :attr:`connected`."""
        return [np.array(p["transformation"], dtype=np.float64) for p in self._report["poses"]]

    @property
    def connected(self) -> List[bool]:
        """Per scan: reached from the first scan through kept edges (else left out of the merged
        cloud, with an ``unconnected_scan`` warning)."""
        return [bool(p["connected"]) for p in self._report["poses"]]

    @property
    def scan_warnings(self) -> List[List[str]]:
        """Per scan: the codes of the :attr:`warnings` that name it (``unconnected_scan``,
        ``single_edge_scan``, ``ambiguous_scans``, ``inconsistent_scans``); with any but the
        first its pose may be wrong."""
        return [list(p["warnings"]) for p in self._report["poses"]]

    @property
    def edges(self) -> List[Dict[str, Any]]:
        """Every pair found to overlap, kept or not, by (source, target): dicts with ``source``,
        ``target`` (input indices), ``source_file``, ``target_file``, ``transformation`` (4x4,
        target ≈ T·source), ``overlap``, ``rms``, ``pairs``, ``free_space``, ``kept``, ``status``
        ("" when kept, else ``weak``, ``inconsistent`` or ``pruned``), ``rotation_residual_deg``,
        ``translation_residual``, ``information`` (6x6 array) and ``warnings``."""
        out = []
        for e in self._report["edges"]:
            d = dict(e)
            d["transformation"] = np.array(e["transformation"], dtype=np.float64)
            d["information"] = np.array(e["information"], dtype=np.float64)
            d["warnings"] = [dict(w) for w in e["warnings"]]
            out.append(d)
        return out

    @property
    def merged(self) -> PointCloud:
        """The merged cloud in the first scan's frame, with normals (one point per voxel)."""
        return self._merged

    @property
    def merged_scan(self) -> np.ndarray:
        """(M,) int32, per merged point: the input index of the scan most of its voxel came
        from (read-only)."""
        return self._merged_scan

    @property
    def report(self) -> Dict[str, Any]:
        """The JSON report, as :meth:`to_dict` (a new dict)."""
        return self.to_dict()

    @property
    def transformation(self) -> np.ndarray:  # type: ignore[override]
        raise AttributeError("a stitch result has one pose per scan: .poses")


def _scan(k: int, value: Any) -> "tuple[PointCloud, str, Optional[np.ndarray]]":
    """Scan ``k`` as a cloud, the path the report shows ("" in memory) and, for a file, its
    sensor's position."""
    if _is_path(value):
        cloud, viewpoint = _read(value, stacklevel=4)  # stitch()'s caller
        return cloud, os.fspath(value), viewpoint
    if isinstance(value, PointCloud):
        return value, "", None
    points = rows(f"scans[{k}]", value)
    try:
        return PointCloud(points), "", None
    except DataError as e:  # name the scan, not "cloud"
        error = DataError(f"scans[{k}]: {e.problem}")
        error.subject, error.problem = f"scans[{k}]", e.problem
        raise error from None


def stitch(scans: Sequence[Any], *, min_overlap: float = _DEFAULTS["min_overlap"],
           voxel: float = _DEFAULTS["voxel"],
           prune_rotation: float = _DEFAULTS["prune_rotation"],
           prune_translation: float = _DEFAULTS["prune_translation"],
           multiview_iterations: int = _DEFAULTS["multiview_iterations"],
           viewpoints: Optional[Any] = None, viewpoint: Optional[Any] = None,
           threads: int = 0,
           report: Optional[PathLike] = None, output: Optional[PathLike] = None,
           figure: Optional[PathLike] = None, html: Optional[PathLike] = None,
           scan_index: bool = True, method: str = _DEFAULTS["method"],
           kernel: str = _DEFAULTS["kernel"], kernel_scale: float = _DEFAULTS["kernel_scale"],
           strict: bool = False) -> StitchResult:
    """Stitches many scans of one object into the frame of the first (``align3d stitch``): a few
    candidate poses per pair, one pose per scan chosen for the whole set, the chosen pairs
    refined, a pose graph optimised, a multi-view ICP, and the scans merged into one cloud with
    normals.

    ``scans``: a list of at least two scans, each an (N, 3) array, a :class:`PointCloud` or a file
    name (mixed as you like); the order carries no meaning but the first gives the frame.
    ``viewpoints``: where each scan's sensor was, in its own frame, (K, 3), a row of NaN where
    not known; None: where the file says (a PCD's VIEWPOINT away from the origin, the origin of
    an organized PCD), else not known. A scan whose sensor is not known gets its frame's origin
    when the scan could have been seen from there (depth cameras and scanners write their own
    coordinates), else a position estimated from the scan; the report's ``poses[k]["sensor"]``
    says which. ``viewpoint``: one position (3,) for every scan (the ``--viewpoint`` flag); not
    with ``viewpoints``. ``min_overlap``, ``voxel``
    (0: from the point spacing), ``prune_rotation`` (degrees), ``prune_translation`` (share of the
    object's diameter), ``multiview_iterations``, ``threads``: as the flags (stitching draws no
    random numbers: it takes no seed).
    ``method`` (``"point-to-plane"``, ``"point-to-point"``, ``"gicp"``, ``"symmetric"``),
    ``kernel`` (``"auto"``: Geman-McClure at half the reach, for the pairs and the multi-view ICP,
    or a kernel as :func:`register` takes) and ``kernel_scale`` (0: from the noise): the ICP cost of
    each pair's refinement and of the multi-view ICP (point-to-plane there for point-to-point),
    as ``--method``, ``--kernel``, ``--kernel-scale``. ``report``,
    ``output`` (PLY; ``scan_index=False`` leaves its ``scan`` property out), ``figure`` (PNG) and
    ``html`` write what the command line writes. Scans that overlap no other are a result
    (``connected`` False, an ``unconnected_scan`` warning), not an exception: the command line's
    exit code 10 has no Python counterpart. Raises ValueError for an array of the wrong shape,
    DataError for fewer than two scans or a scan that cannot be used (naming its file),
    FileError for a file that cannot be read; with ``strict``, warnings raise StrictError."""
    if _is_path(scans) or isinstance(scans, (PointCloud, np.ndarray)):
        raise TypeError(f"scans: expected a list of scans, got one {type(scans).__name__}")
    loaded = []
    for k, value in enumerate(scans):  # a loop, not a comprehension: the warnings' stack level
        loaded.append(_scan(k, value))
    if len(loaded) < 2:
        error = DataError(f"scans: {len(loaded)} given; stitching needs at least two")
        error.subject, error.problem = "scans", f"{len(loaded)} given; stitching needs at least two"
        raise error
    if viewpoint is not None:
        if viewpoints is not None:
            raise ValueError("viewpoint and viewpoints: give one or the other")
        eye = np.asarray(viewpoint, dtype=np.float64)
        if eye.shape != (3,) or not np.isfinite(eye).all():
            raise ValueError(f"viewpoint: expected 3 finite numbers, got shape {eye.shape}")
        eyes = np.repeat(eye[None, :], len(loaded), axis=0)
    elif viewpoints is None:
        unknown = np.full(3, np.nan)
        eyes = np.array([unknown if v is None else v for _, _, v in loaded], dtype=np.float64)
    else:
        eyes = rows("viewpoints", viewpoints, len(loaded))
    text, merged, merged_scan = _core.stitch(
        [c._cloud for c, _, _ in loaded], min_overlap=_real("min_overlap", min_overlap),
        voxel=_real("voxel", voxel), prune_rotation=_real("prune_rotation", prune_rotation),
        prune_translation=_real("prune_translation", prune_translation),
        multiview_iterations=_int32("multiview_iterations", multiview_iterations),
        viewpoints=eyes, threads=_int32("threads", threads),
        paths=[p for _, p, _ in loaded], output=os.fspath(output) if output else "",
        figure=os.fspath(figure) if figure else "", html=os.fspath(html) if html else "",
        scan_index=bool(scan_index), method=_text("method", method),
        kernel=_text("kernel", kernel), kernel_scale=_real("kernel_scale", kernel_scale))
    result = StitchResult(json.loads(text), PointCloud._wrap(merged), merged_scan)
    if report is not None:
        _write_report(report, text)
    if strict and result.warnings:
        raise StrictError(f"{len(result.warnings)} warning(s): "
                          + "; ".join(w.code for w in result.warnings), result)
    _warn_all(result.warnings)
    return result
