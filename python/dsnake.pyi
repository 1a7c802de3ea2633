# Type stubs of the module dsnake (python/); docs/python.md describes it.
from os import PathLike
from typing import Any, Callable, Mapping, Optional, Union

import numpy as np
import numpy.typing as npt

class Error(RuntimeError): ...
class InputError(Error): ...
class DivergenceError(Error):
    result: Result

Config = Union[str, "PathLike[str]", Mapping[str, Any]]

class Result:
    dimension: int
    vertices: npt.NDArray[np.float64]        # N x D, world mm
    faces: Optional[npt.NDArray[np.int32]]   # 3D: F x 3; 2D: None
    order: Optional[npt.NDArray[np.int32]]   # 2D: vertex indices along the contour; 3D: None
    template_ids: npt.NDArray[np.int32]      # N, -1 for inserted vertices
    correspondence: dict[str, npt.NDArray[Any]]
    metrics: dict[str, Optional[float]]
    success: bool
    status: str
    trace: dict[str, npt.NDArray[Any]]
    config: dict[str, Any]
    result: dict[str, Any]

def run(config: Config, out: Optional[Union[str, "PathLike[str]"]] = None,
        progress: Optional[Callable[[dict[str, Any]], None]] = None) -> Result: ...
