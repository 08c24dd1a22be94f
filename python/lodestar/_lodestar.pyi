"""Type stubs of the extension module; the documented interface is ``lodestar/__init__.py``."""

from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np

def render(
    scene: Optional[str],
    is_text: bool,
    integrator: Optional[str],
    spp: Optional[int],
    time: Optional[float],
    seed: int,
    threads: Optional[int],
    max_depth: Optional[int],
    options: List[str],
    defines: List[Tuple[str, str]],
    progress: Optional[Callable[[float], None]],
) -> Tuple[np.ndarray, Dict[str, Any]]: ...
def bench(
    scene: str,
    integrators: List[str],
    time: float,
    reference: str,
    runs: int,
    seed: int,
    threads: int,
    max_depth: Optional[int],
    defines: List[Tuple[str, str]],
    out: str,
    progress: Optional[Callable[[float], None]],
) -> List[Dict[str, Any]]: ...
def compare(image: np.ndarray, reference: np.ndarray) -> Dict[str, Any]: ...
def integrators() -> List[Dict[str, Any]]: ...
def read_exr(path: str) -> np.ndarray: ...
def write_exr(path: str, image: np.ndarray) -> None: ...
