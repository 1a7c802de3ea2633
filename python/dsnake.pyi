# Type stubs of the module dsnake (python/); docs/python.md describes it.
from os import PathLike
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

Path = Union[str, "PathLike[str]"]
Config = Union[str, "PathLike[str]", Mapping[str, Any]]
Float64Array = npt.NDArray[np.float64]

class Error(RuntimeError):
    """Every error of dsnake; the message is the command line's one line."""

class InputError(Error):
    """Bad input: a file, a key or an argument; the message names it."""

class DivergenceError(Error):
    """A run stopped by the watchdog; .result holds the Result at its last good positions."""
    result: Result

class Result:
    dimension: int
    vertices: Float64Array                   # N x D, world (LPS) mm
    faces: Optional[npt.NDArray[np.int32]]   # 3D: F x 3; 2D: None
    order: Optional[npt.NDArray[np.int32]]   # 2D: vertex indices along the contour; 3D: None
    template_ids: npt.NDArray[np.int32]      # N, -1 for inserted vertices
    correspondence: dict[str, npt.NDArray[Any]]  # template_id, initial, final, target, error
    metrics: dict[str, Optional[float]]
    success: bool
    status: str                              # converged, iteration_budget or diverged
    trace: dict[str, npt.NDArray[Any]]       # one row per iteration
    config: dict[str, Any]                   # the experiment as run
    result: dict[str, Any]                   # result.json's document

def run(config: Config, out: Optional[Path] = None,
        progress: Optional[Callable[[dict[str, Any]], None]] = None) -> Result: ...

class Image:
    def __init__(self, array: npt.ArrayLike, spacing: Optional[Sequence[float]] = None,
                 origin: Optional[Sequence[float]] = None, direction: Optional[npt.ArrayLike] = None) -> None: ...
    @property
    def array(self) -> npt.NDArray[np.float32]: ...   # [z, y, x] or [y, x], a view without a copy
    @property
    def dimension(self) -> int: ...
    @property
    def spacing(self) -> list[float]: ...             # (x, y[, z]) mm
    @property
    def origin(self) -> list[float]: ...              # (x, y[, z]) mm, LPS
    @property
    def direction(self) -> Float64Array: ...          # D x D, columns: the voxel axes in world

def read_image(path: Path) -> Image: ...
def write_image(image: Image, path: Path, label: bool = False, compress: bool = False) -> None: ...
def read_mesh(path: Path, dimension: int = 3) -> Tuple[Float64Array, Optional[npt.NDArray[np.int32]]]: ...
def write_mesh(path: Path, vertices: Float64Array, faces: Optional[npt.ArrayLike] = None) -> None: ...

def field(image: Image, type: str = "gvf", **options: Any) -> npt.NDArray[np.float32]: ...

class Energy:
    def value(self, q: Float64Array) -> float: ...
    def propose(self, q: Float64Array) -> Float64Array: ...

def energy(type: str, template: Union[Float64Array, Tuple[Float64Array, npt.ArrayLike]],
           image: Optional[Image] = None, field: Optional[Mapping[str, Any]] = None, **options: Any) -> Energy: ...

def schema() -> dict[str, Any]: ...
def sweep(config: Path, out: Path, jobs: int = 1) -> Any: ...  # a pandas DataFrame, or a list of dicts
