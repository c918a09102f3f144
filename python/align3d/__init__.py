"""align3d: rigid registration, CAD inspection and rectification of 3D point clouds and meshes.

A thin layer over the C++ library (docs/python.md): numpy arrays in and out, keyword settings
named after the flags of the ``align3d`` command line, results whose ``to_dict()`` is the
command line's JSON report, C++ errors as Python exceptions.

Convention: a transformation is a 4x4 float64 array, row-major, mapping SOURCE into TARGET's
frame (target ≈ T·source). Units are the data's (mm, m, ...): every default distance follows the
data, so the same clouds in mm or m give the same pose.

>>> import align3d
>>> align3d.synth("scene")                                   # doctest: +SKIP
>>> r = align3d.register("scene/scan.ply", "scene/model.ply")  # doctest: +SKIP
>>> r.transformation, r.rms, r.converged                       # doctest: +SKIP
"""

from . import _core
from ._cloud import PointCloud, read_matrix, read_point_cloud, write_matrix, write_point_cloud
from ._commands import convert, demo, evaluate, ppf_model, synth
from ._errors import (
    AlignWarning,
    DataError,
    Error,
    FileError,
    NoSolutionError,
    SettingsError,
    StrictError,
)
from ._find import FindResult, find, match_instances
from ._inspect import InspectResult, inspect
from ._mesh import TriangleMesh, is_mesh_file, read_mesh, write_mesh
from ._register import RectifyResult, Result, rectify, register
from ._stitch import StitchResult, stitch
from ._target import Target

__version__: str = _core.__version__


def __getattr__(name: str):  # align3d.batch on first use: it imports Dask only then
    if name == "batch":
        import importlib

        return importlib.import_module(".batch", __name__)
    raise AttributeError(f"module 'align3d' has no attribute {name!r}")

__all__ = [
    "AlignWarning",
    "DataError",
    "Error",
    "FileError",
    "InspectResult",
    "NoSolutionError",
    "PointCloud",
    "RectifyResult",
    "Result",
    "SettingsError",
    "StrictError",
    "StitchResult",
    "Target",
    "TriangleMesh",
    "convert",
    "demo",
    "evaluate",
    "inspect",
    "find",
    "match_instances",
    "FindResult",
    "is_mesh_file",
    "ppf_model",
    "read_matrix",
    "read_mesh",
    "read_point_cloud",
    "rectify",
    "register",
    "stitch",
    "synth",
    "write_matrix",
    "write_mesh",
    "write_point_cloud",
]
