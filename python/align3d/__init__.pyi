# Type stubs of the align3d package (python/tests/test_api.py checks them against the code:
# every public name, every parameter). Docs: docs/python.md and the docstrings.
import os
from typing import Any, Callable, Dict, List, Optional, Union

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
def register(
    source: CloudLike,
    target: CloudLike,
    *,
    init: Union[str, Matrix] = ...,
    method: str = ...,
    global_method: str = ...,
    ppf_model: Optional[PathLike] = ...,
    voxel: float = ...,
    seed: int = ...,
    mutual: bool = ...,
    reject: str = ...,
    max_iterations: int = ...,
    tolerance: float = ...,
    normal_k: int = ...,
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
    azimuth: Optional[float] = ...,
    angle: Optional[float] = ...,
    views: Optional[int] = ...,
) -> Dict[str, Any]: ...
def evaluate(
    outdir: PathLike = ...,
    *,
    trials: Optional[int] = ...,
    cell_trials: Optional[int] = ...,
    seed: Optional[int] = ...,
    quick: bool = ...,
    threads: Optional[int] = ...,
) -> Dict[str, Any]: ...
def demo(
    outdir: PathLike = ...,
    *,
    scene: Optional[PathLike] = ...,
    seed: Optional[int] = ...,
    threads: Optional[int] = ...,
) -> Dict[str, Any]: ...
def convert(input: PathLike, output: PathLike, *, encoding: Optional[str] = ...) -> None: ...
def ppf_model(model: PathLike, out: PathLike, *, voxel: Optional[float] = ...) -> None: ...
