# Type stubs of the align3d package (python/tests/test_api.py checks them against the code:
# every public name, every parameter). Docs: docs/python.md and the docstrings.
import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, os.PathLike[str]]
ArrayLike = npt.ArrayLike
Matrix = Union[npt.ArrayLike, PathLike]  # a 4x4 array, or a transform file
CloudLike = Union["PointCloud", npt.ArrayLike, PathLike]
Progress = Callable[[str, int, int], Any]

class Error(Exception):
    code: int

class FileError(Error, OSError):
    code: int
    def __init__(self, message: str, path: Optional[str] = ...) -> None: ...
    @property
    def path(self) -> Optional[str]: ...
    @path.setter
    def path(self, value: Optional[str]) -> None: ...

class DataError(Error, ValueError):
    code: int
    subject: str
    problem: str

class SettingsError(Error, ValueError):
    code: int

class NoSolutionError(Error):
    code: int
    result: Result
    def __init__(self, message: str, result: Any = ...) -> None: ...

class StrictError(Error):
    code: int
    result: Union[Result, RectifyResult]
    warnings: List[AlignWarning]
    def __init__(self, message: str, result: Any = ...) -> None: ...

class AlignWarning(UserWarning):
    code: str
    message: str
    def __init__(self, code: str, message: str) -> None: ...

class PointCloud:
    def __init__(self, points: ArrayLike, normals: Optional[ArrayLike] = ...) -> None: ...
    @property
    def points(self) -> npt.NDArray[np.float64]: ...
    @points.setter
    def points(self, value: ArrayLike) -> None: ...
    @property
    def normals(self) -> Optional[npt.NDArray[np.float64]]: ...
    @normals.setter
    def normals(self, value: ArrayLike) -> None: ...
    @property
    def has_normals(self) -> bool: ...
    def __len__(self) -> int: ...
    def transformed(self, transformation: ArrayLike) -> PointCloud: ...
    def copy(self) -> PointCloud: ...

class Result:
    def to_dict(self) -> Dict[str, Any]: ...
    @property
    def transformation(self) -> npt.NDArray[np.float64]: ...
    @property
    def warnings(self) -> List[AlignWarning]: ...
    @property
    def success(self) -> bool: ...
    @property
    def failure(self) -> Optional[str]: ...
    @property
    def rms(self) -> float: ...
    @property
    def covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def pending_sigmas(self) -> float: ...
    @property
    def fitness(self) -> float: ...
    @property
    def correspondences(self) -> int: ...
    @property
    def converged(self) -> bool: ...
    @property
    def stop_reason(self) -> str: ...
    @property
    def iterations(self) -> int: ...
    @property
    def history(self) -> List[Dict[str, Any]]: ...
    @property
    def stages(self) -> List[Dict[str, Any]]: ...
    @property
    def rotation_deg(self) -> float: ...
    @property
    def translation(self) -> npt.NDArray[np.float64]: ...
    @property
    def support(self) -> Dict[str, Any]: ...
    @property
    def init(self) -> Dict[str, Any]: ...
    @property
    def global_stage(self) -> Optional[Dict[str, Any]]: ...
    @property
    def icp_direction(self) -> str: ...
    @property
    def degenerate_directions(self) -> List[Dict[str, Any]]: ...
    @property
    def rotation_error_deg(self) -> Optional[float]: ...
    @property
    def translation_error(self) -> Optional[float]: ...
    @property
    def timing_ms(self) -> Dict[str, float]: ...

class RectifyResult:
    def to_dict(self) -> Dict[str, Any]: ...
    @property
    def transformation(self) -> npt.NDArray[np.float64]: ...
    @property
    def warnings(self) -> List[AlignWarning]: ...
    @property
    def normal(self) -> npt.NDArray[np.float64]: ...
    @property
    def tilt_before_deg(self) -> float: ...
    @property
    def tilt_after_deg(self) -> float: ...
    @property
    def inliers(self) -> int: ...
    @property
    def flatness(self) -> float: ...
    @property
    def rms(self) -> float: ...
    @property
    def noise(self) -> float: ...
    @property
    def fit(self) -> str: ...

def read_point_cloud(path: PathLike) -> PointCloud: ...
def write_point_cloud(path: PathLike, cloud: Union[PointCloud, ArrayLike], *,
                      encoding: Optional[str] = ...) -> None: ...
def read_matrix(path: PathLike) -> npt.NDArray[np.float64]: ...
def write_matrix(path: PathLike, transformation: ArrayLike) -> None: ...
class TriangleMesh:
    def __init__(self, vertices: ArrayLike, triangles: ArrayLike) -> None: ...
    @property
    def vertices(self) -> npt.NDArray[np.float64]: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...
    def __len__(self) -> int: ...
    def area(self) -> float: ...
    def diagonal(self) -> float: ...
    def topology(self) -> Dict[str, Any]: ...
    def cleaned(self) -> TriangleMesh: ...
    def sample(self, count: int, *, seed: int = ...) -> PointCloud: ...

def is_mesh_file(path: PathLike) -> bool: ...
def read_mesh(path: PathLike, *, chord_tolerance: float = ...) -> TriangleMesh: ...
def write_mesh(path: PathLike, mesh: TriangleMesh) -> None: ...
class Target:
    def __init__(self, cloud: Union[CloudLike, TriangleMesh], *, normal_k: int = ...,
                 threads: int = ...) -> None: ...
    @property
    def path(self) -> str: ...
    @property
    def normal_k(self) -> int: ...
    @property
    def is_mesh(self) -> bool: ...
    def __len__(self) -> int: ...

class InspectResult:
    def __init__(self, report: Dict[str, Any], deviations: npt.NDArray[np.float64],
                 closest: npt.NDArray[np.float64], triangles: npt.NDArray[np.int64]) -> None: ...
    def to_dict(self) -> Dict[str, Any]: ...
    @property
    def transformation(self) -> npt.NDArray[np.float64]: ...
    @property
    def warnings(self) -> List[AlignWarning]: ...
    @property
    def deviations(self) -> npt.NDArray[np.float64]: ...
    @property
    def closest_points(self) -> npt.NDArray[np.float64]: ...
    @property
    def triangles(self) -> npt.NDArray[np.int64]: ...
    @property
    def verdict(self) -> str: ...
    @property
    def passed(self) -> bool: ...
    @property
    def within_tolerance(self) -> float: ...
    @property
    def outliers(self) -> int: ...
    @property
    def tolerance(self) -> Tuple[float, float]: ...
    @property
    def stats(self) -> Dict[str, float]: ...
    @property
    def gauss_fit(self) -> Dict[str, float]: ...

def inspect(
    scan: CloudLike,
    cad: Union[TriangleMesh, Target, PathLike],
    *,
    tolerance: Union[float, Tuple[float, float]],
    init: Union[str, Matrix] = ...,
    method: str = ...,
    kernel: str = ...,
    kernel_scale: float = ...,
    max_distance: float = ...,
    pass_fraction: float = ...,
    seed: int = ...,
    threads: int = ...,
    chord_tolerance: float = ...,
    output: Optional[PathLike] = ...,
    csv: Optional[PathLike] = ...,
    histogram: Optional[PathLike] = ...,
    html: Optional[PathLike] = ...,
    figures: Optional[PathLike] = ...,
    units: str = ...,
    report: Optional[PathLike] = ...,
    strict: bool = ...,
) -> InspectResult: ...

def register(
    source: CloudLike,
    target: Union[CloudLike, TriangleMesh, Target],
    *,
    init: Union[str, Matrix] = ...,
    method: str = ...,
    kernel: str = ...,
    kernel_scale: float = ...,
    global_method: str = ...,
    ppf_model: Optional[PathLike] = ...,
    voxel: float = ...,
    seed: int = ...,
    mutual: bool = ...,
    reject: str = ...,
    max_iterations: int = ...,
    tolerance: float = ...,
    normal_k: Optional[int] = ...,
    model_error: bool = ...,
    threads: int = ...,
    ground_truth: Optional[Matrix] = ...,
    output: Optional[PathLike] = ...,
    report: Optional[PathLike] = ...,
    strict: bool = ...,
    progress: Optional[Progress] = ...,
) -> Result: ...
def rectify(
    cloud: CloudLike,
    *,
    fit: str = ...,
    up: Optional[ArrayLike] = ...,
    seed: int = ...,
    output: Optional[PathLike] = ...,
    report: Optional[PathLike] = ...,
    strict: bool = ...,
) -> RectifyResult: ...
def synth(
    outdir: PathLike,
    *,
    scene: Optional[str] = ...,
    seed: Optional[int] = ...,
    variant: Optional[str] = ...,
    points: Optional[int] = ...,
    instances: Optional[int] = ...,
    part: Optional[str] = ...,
    distractors: Optional[int] = ...,
    azimuth: Optional[float] = ...,
    angle: Optional[float] = ...,
    views: Optional[int] = ...,
    noise: Optional[float] = ...,
    triangles: Optional[int] = ...,
    no_leaf: bool = ...,
) -> Dict[str, Any]: ...
def evaluate(
    outdir: PathLike = ...,
    *,
    trials: Optional[int] = ...,
    cell_trials: Optional[int] = ...,
    seed: Optional[int] = ...,
    quick: bool = ...,
    scenes_only: bool = ...,
    scenes: Optional[Sequence[PathLike]] = ...,
    threads: Optional[int] = ...,
) -> Dict[str, Any]: ...
def demo(
    outdir: PathLike = ...,
    *,
    scene: Optional[PathLike] = ...,
    seed: Optional[int] = ...,
    threads: Optional[int] = ...,
) -> Dict[str, Any]: ...
def convert(input: PathLike, output: PathLike, *, encoding: Optional[str] = ...,
            sample: Optional[int] = ..., chord_tolerance: Optional[float] = ...) -> None: ...
def ppf_model(model: PathLike, out: PathLike, *, voxel: Optional[float] = ...,
              find: bool = ..., voxel_fraction: Optional[float] = ...) -> None: ...

class FindResult:
    def __init__(self, report: Dict[str, Any]) -> None: ...
    def to_dict(self) -> Dict[str, Any]: ...
    @property
    def transformation(self) -> npt.NDArray[np.float64]: ...
    @property
    def warnings(self) -> List[AlignWarning]: ...
    @property
    def instances(self) -> List[Dict[str, Any]]: ...

def find(
    model: Any,
    scene: PathLike,
    *,
    max_instances: int = ...,
    min_score: float = ...,
    symmetry: str = ...,
    voxel_fraction: float = ...,
    keep_plane: bool = ...,
    depth_range: Optional[Sequence[float]] = ...,
    seed: int = ...,
    threads: int = ...,
    report: Optional[PathLike] = ...,
    output: Optional[PathLike] = ...,
    image: Optional[PathLike] = ...,
    method: str = ...,
    kernel: str = ...,
    kernel_scale: float = ...,
    strict: bool = ...,
) -> FindResult: ...

def match_instances(
    model_points: Any,
    found: Sequence[Any],
    truth: Sequence[Any],
    visible: Sequence[float],
    max_error: float,
    *,
    min_visible: float = ...,
) -> Dict[str, Any]: ...

class StitchResult:
    def __init__(
        self, report: Dict[str, Any], merged: PointCloud, merged_scan: npt.NDArray[np.int32]
    ) -> None: ...
    def to_dict(self) -> Dict[str, Any]: ...
    @property
    def transformation(self) -> npt.NDArray[np.float64]: ...
    @property
    def warnings(self) -> List[AlignWarning]: ...
    @property
    def poses(self) -> List[npt.NDArray[np.float64]]: ...
    @property
    def connected(self) -> List[bool]: ...
    @property
    def scan_warnings(self) -> List[List[str]]: ...
    @property
    def edges(self) -> List[Dict[str, Any]]: ...
    @property
    def merged(self) -> PointCloud: ...
    @property
    def merged_scan(self) -> npt.NDArray[np.int32]: ...
    @property
    def report(self) -> Dict[str, Any]: ...

def stitch(
    scans: Sequence[CloudLike],
    *,
    min_overlap: float = ...,
    voxel: float = ...,
    prune_rotation: float = ...,
    prune_translation: float = ...,
    multiview_iterations: int = ...,
    viewpoints: Optional[ArrayLike] = ...,
    viewpoint: Optional[ArrayLike] = ...,
    threads: int = ...,
    report: Optional[PathLike] = ...,
    output: Optional[PathLike] = ...,
    figure: Optional[PathLike] = ...,
    html: Optional[PathLike] = ...,
    scan_index: bool = ...,
    method: str = ...,
    kernel: str = ...,
    kernel_scale: float = ...,
    strict: bool = ...,
) -> StitchResult: ...
