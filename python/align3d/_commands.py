"""The file-to-file commands of the ``align3d`` tool, run in-process: the same code, checks,
defaults and outputs as the command line, errors raised as exceptions. A keyword left at None
takes the command's default (``align3d COMMAND --help`` shows them)."""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from . import _core
from ._cloud import PathLike
from ._errors import AlignWarning

_WARNING = "align3d: warning: "


def _option_text(name: str, value: Any) -> str:
    if isinstance(value, bool) or not isinstance(value, (int, float, str, os.PathLike)):
        raise TypeError(f"{name}: expected a number or a string, got {type(value).__name__}")
    if isinstance(value, float):
        return repr(value)  # round-trips exactly
    return os.fspath(value) if isinstance(value, os.PathLike) else str(value)


def run(command: str, positional: List[Any], options: Dict[str, Any],
        flags: Optional[Dict[str, bool]] = None) -> str:
    """Runs ``align3d COMMAND --option=value ... [--flag ...] -- POSITIONAL...`` in-process and
    returns its stdout. Options that are None are left out (the command's default); every
    ``align3d: warning:`` line on stderr is issued as an AlignWarning (code ``file``)."""
    args = [command]
    for name, value in options.items():
        if value is not None:
            args.append(f"--{name.replace('_', '-')}={_option_text(name, value)}")
    for name, on in (flags or {}).items():
        if on:
            args.append(f"--{name.replace('_', '-')}")
    args.append("--")  # positionals after it are never taken for flags
    args += [os.fspath(p) for p in positional]
    _, out, err = _core.run_command(args)
    for line in err.splitlines():
        if line.startswith(_WARNING):
            warnings.warn(AlignWarning("file", line[len(_WARNING):]), stacklevel=3)
    return out


def _json(path: Path) -> Dict[str, Any]:
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def synth(
    outdir: PathLike,
    *,
    scene: Optional[str] = None,
    seed: Optional[int] = None,
    variant: Optional[str] = None,
    points: Optional[int] = None,
    instances: Optional[int] = None,
    part: Optional[str] = None,
    distractors: Optional[int] = None,
    azimuth: Optional[float] = None,
    angle: Optional[float] = None,
    views: Optional[int] = None,
    noise: Optional[float] = None,
    triangles: Optional[int] = None,
    no_leaf: bool = False,
) -> Dict[str, Any]:
    """Writes a synthetic scene with ground truth into ``outdir`` (``align3d synth``; created if
    missing) and returns its ``scene.json`` as a dict. Units: mm.

    ``scene``: ``"chapter"`` (default: the conveyor scene: ``model.ply`` the target,
    ``scan.ply`` the source, ``ground_truth.txt`` with model ≈ T·scan, ``plate.ply`` and
    ``plate_cluttered.ply``; ``variant`` picks a harder geometry: ``wide-plane``,
    ``small-features``, ``large-offset``, ``extreme``), ``"parts"`` (a work cell of ``points``
    points a cloud), ``"bin"`` (an organized depth image ``scene.pcd`` of a bin into which ``instances`` copies of
    ``part`` — ``"bracket"``, no symmetry, ``"flange"``, rotationally symmetric, or ``"plate"``,
    mostly flat — and
    ``distractors`` other objects were dropped; ``model.stl``, each instance's pose and visible
    fraction) or
    ``"views"`` (``views`` range scans of an object, the first at ``azimuth``, then every
    ``angle`` degrees) or ``"part"`` (a machined part's CAD mesh ``part.stl`` and its as-built
    scan with dents, bumps, warp, noise ``noise`` (mm), a fixture and a known pose, about
    ``points`` points from ``views`` (1 or 2) viewpoints; ``triangles`` also writes
    ``part_fine.stl`` subdivided to at least that many triangles; ``scan_truth.ply`` holds each
    point's label and true deviation) or ``"stitch"`` (``views`` range scans ``scan_00.ply`` …
    of ``part`` around it, each in its sensor's frame, listed in ``scans.txt``, plus a leaf view
    that overlaps one other unless ``no_leaf``; the truth is ``truth.json``, returned). ``seed``: the same seed writes the same bytes (default 39).
    Read the clouds with :func:`read_point_cloud` and the truth with :func:`read_matrix`."""
    run("synth", [outdir], dict(scene=scene, seed=seed, variant=variant, points=points,
                                instances=instances, part=part, distractors=distractors,
                                azimuth=azimuth, angle=angle, views=views,
                                noise=noise, triangles=triangles), dict(no_leaf=no_leaf))
    return _json(Path(outdir) / ("truth.json" if scene == "stitch" else "scene.json"))


def evaluate(
    outdir: PathLike = "align3d_evaluation",
    *,
    trials: Optional[int] = None,
    cell_trials: Optional[int] = None,
    seed: Optional[int] = None,
    quick: bool = False,
    scenes_only: bool = False,
    scenes: Optional[Sequence[PathLike]] = None,
    threads: Optional[int] = None,
) -> Dict[str, Any]:
    """Measures registration from random starting poses (``align3d evaluate``): success rates of
    ICP alone (each metric), global + ICP and the default ``init="auto"`` on the chapter scene,
    two object views (a bracket, a bumpy sphere) and two range scans of an animal, and the
    convergence basins. Writes ``evaluation.md``, ``evaluation.json`` and
    ``basin_<scene>.svg``/``.png`` into ``outdir`` and returns ``evaluation.json`` as a dict
    (``success``: one row per scene and method; ``basin``: one grid per scene and method, with its
    ``scene``; ``scenes``: each scene's files, written into ``outdir/scenes/<name>/``:
    ``source.ply``, ``target.ply`` and ``truth.txt``, target ≈ T·source). The full run takes
    about half an hour on 2 cores; ``quick=True`` (3 trials, a 2×2 basin) checks the machinery in
    seconds; ``scenes_only=True`` writes the scenes and measures nothing. ``scenes`` picks which:
    built-in names (``"chapter"``, ``"bracket"``, ``"bumpy-sphere"``, ``"animal"``) or directories
    of your own, each holding ``source.*`` and ``target.*`` (clouds) and ``truth.txt`` (4×4,
    target ≈ T·source), named after the directory (paths without commas)."""
    chosen = None
    if scenes is not None:
        if isinstance(scenes, (str, os.PathLike)):
            raise TypeError("scenes: expected a list of names or directories, got one string")
        chosen = ",".join(os.fspath(each) for each in scenes)
    run("evaluate", [outdir],
        dict(trials=trials, cell_trials=cell_trials, seed=seed, scenes=chosen, threads=threads),
        dict(quick=quick, scenes_only=scenes_only, quiet=True))
    return _json(Path(outdir) / "evaluation.json")


def demo(
    outdir: PathLike = "align3d_demo",
    *,
    scene: Optional[PathLike] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
) -> Dict[str, Any]:
    """Reproduces the chapter's experiments (``align3d demo``) on a generated scene (``seed``) or
    on a directory written by :func:`synth` (``scene``); writes ``table.md``, ``results.json``,
    figures ``fig39_1`` … ``fig39_6`` and ``report.html`` into ``outdir`` and returns
    ``results.json`` as a dict (one registration report per experiment under ``icp``)."""
    run("demo", [outdir], dict(scene=scene, seed=seed, threads=threads), dict(quiet=True))
    return _json(Path(outdir) / "results.json")


def convert(
    input: PathLike,
    output: PathLike,
    *,
    encoding: Optional[str] = None,
    sample: Optional[int] = None,
    chord_tolerance: Optional[float] = None,
) -> None:
    """Converts a cloud file between PLY, PCD and XYZ/TXT/CSV, each by its extension
    (``align3d convert``). Normals are kept where ``output``'s format holds them; a PCD's
    VIEWPOINT is kept into a PCD; points with a NaN or Inf coordinate are dropped (with an
    :class:`AlignWarning`). ``encoding`` as :func:`write_point_cloud`'s. A mesh (``.stl``,
    ``.obj``, ``.off``, ``.ply`` with faces, STEP/IGES tessellated to ``chord_tolerance``)
    converts into a mesh format, or into a cloud format with ``sample`` points spread evenly by
    area. Written atomically."""
    run("convert", [input, output],
        dict(encoding=encoding, sample=sample, chord_tolerance=chord_tolerance))


def ppf_model(model: PathLike, out: PathLike, *, voxel: Optional[float] = None,
              find: bool = False, voxel_fraction: Optional[float] = None) -> None:
    """Builds the point-pair-feature description of the cloud or mesh file ``model`` and saves it
    to ``out`` (``align3d ppf-model``), for ``register(scan, model, ppf_model=out)`` on many scans.
    ``voxel`` in data units (default 0: the model's extent / 50, as register's global stage).
    With ``find``, the description :func:`find` takes instead (outward normals, sampled with
    ``voxel_fraction`` of the model's diameter)."""
    run("ppf-model", [model, out], dict(voxel=voxel, voxel_fraction=voxel_fraction),
        dict(find=find))
