"""lodestar from Python: render, bench and compare with the renderer's integrators.

    import lodestar
    image, stats = lodestar.render("scenes/pool.toml", integrator="guided-bdpt", time=10)
    image.shape          # (H, W, 3), float32, linear RGB
    stats["spp"], stats["seconds"]

Every function runs the same code as the ``lodestar`` command line; see docs/python.md.
Renders run with the GIL released; Ctrl-C stops a render after the pass under way and
raises ``KeyboardInterrupt``.
"""

from __future__ import annotations

import os
import tempfile
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _lodestar

__all__ = [
    "render",
    "bench",
    "compare",
    "integrators",
    "read_exr",
    "write_exr",
]

Scene = Union[str, "os.PathLike[str]", None]


def _scene_arg(scene: Scene) -> Tuple[Optional[str], bool]:
    """(text or path, whether it is text). A ``str`` holding a newline or a ``[`` is TOML
    text; any other ``str`` or path-like is a file (TOML, or Mitsuba XML by its ``.xml``)."""
    if scene is None:
        return None, False
    if isinstance(scene, os.PathLike):
        return os.fspath(scene), False
    if not isinstance(scene, str):
        raise TypeError(f"scene: expected a path, a TOML string or None, got {type(scene).__name__}")
    return scene, ("\n" in scene or "[" in scene)


def _options(options: Optional[Mapping[str, Any]]) -> List[str]:
    out = []
    for k, v in (options or {}).items():
        if isinstance(v, bool):
            v = "true" if v else "false"
        out.append(f"{k}={v}")
    return out


def render(
    scene: Scene = None,
    integrator: Optional[str] = None,
    *,
    spp: Optional[int] = None,
    time: Optional[float] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    max_depth: Optional[int] = None,
    options: Optional[Mapping[str, Any]] = None,
    defines: Optional[Mapping[str, Any]] = None,
    progress: Optional[Callable[[float], None]] = None,
) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Render a scene; returns ``(image, stats)``.

    scene:      a scene file (TOML, or Mitsuba XML by extension), a TOML text, or ``None`` for
                the built-in Cornell box.
    integrator: a registered name (``integrators()``); default: the scene's, else ``pt``.
    spp, time:  the budget: samples (passes) per pixel, or seconds; at most one of them
                (default: the scene's ``spp``).
    seed:       the image is a function of the seed alone, whatever the thread count.
    threads:    default: every core.
    max_depth:  maximum number of path segments (default: the scene's).
    options:    the integrator's ``-O`` options, e.g. ``{"alpha": 0.5, "seeder": "mcmc"}``.
    defines:    a Mitsuba scene's ``$name`` parameters (``-D``).
    progress:   called with the fraction of the budget spent (0 to 1), from the calling
                thread, about twenty times a second and once at the end; an exception it
                raises stops the render and is raised.

    image: float32 NumPy array H x W x 3, linear RGB, top row first.
    stats: ``integrator``, ``settings``, ``spp``, ``passes``, ``seconds``, ``cpu_seconds``,
           ``seed``, ``threads``, ``scene``, and every counter the integrator reports (as in
           the EXR header the command line writes).
    """
    text, is_text = _scene_arg(scene)
    return _lodestar.render(
        text,
        is_text,
        integrator,
        spp,
        time,
        seed,
        threads,
        max_depth,
        _options(options),
        [(str(k), str(v)) for k, v in (defines or {}).items()],
        progress,
    )


def bench(
    scene: Union[str, "os.PathLike[str]"],
    integrators: List[str],
    *,
    time: float,
    reference: Union[str, "os.PathLike[str]"],
    runs: int = 3,
    seed: int = 0,
    threads: int = 1,
    max_depth: Optional[int] = None,
    defines: Optional[Mapping[str, Any]] = None,
    out: Union[str, "os.PathLike[str]", None] = None,
    progress: Optional[Callable[[float], None]] = None,
) -> List[Dict[str, Any]]:
    """Equal-time comparison, as ``lodestar bench``: every integrator renders ``runs`` times
    for ``time`` seconds (seeds ``seed``, ``seed + 1``, ...) and is compared with
    ``reference`` (an EXR of the scene's resolution).

    integrators: names with options, as on the command line: ``"guided-bdpt:alpha=0.5"``.
    defines:     a Mitsuba scene's ``$name`` parameters (``-D``).
    out:         where the report, images and plot go (default: a temporary directory,
                 removed afterwards).
    progress:    called with the fraction of renders done; Ctrl-C (or an exception in it)
                 ends the bench after the render under way.

    Returns one dict per run and one median row per integrator (``median`` True), ready for
    ``pandas.DataFrame``: ``integrator``, ``run``, ``median``, ``seed``, ``runs``,
    ``seconds``, ``spp``, ``passes``, ``mse``, ``rmse``, ``rel_mse``, ``speedup`` (the first
    integrator's MSE over this one's), ``variance``, ``var_speedup``.
    """
    pairs = [(str(k), str(v)) for k, v in (defines or {}).items()]
    args = (os.fspath(scene), list(integrators), float(time), os.fspath(reference), runs, seed, threads, max_depth, pairs)
    if out is None:
        with tempfile.TemporaryDirectory(prefix="lodestar-bench-") as tmp:
            return _lodestar.bench(*args, os.path.join(tmp, "bench"), progress)
    return _lodestar.bench(*args, os.fspath(out), progress)


def compare(image: np.ndarray, reference: np.ndarray) -> Dict[str, Any]:
    """Errors of ``image`` against ``reference`` (both H x W x 3), as ``lodestar compare``:
    ``mse``, ``rmse``, ``rel_mse`` (relative MSE, epsilon 0.01), ``mean``,
    ``mean_reference``."""
    return _lodestar.compare(_rgb(image, "image"), _rgb(reference, "reference"))


def integrators() -> List[Dict[str, Any]]:
    """The registered integrators: ``name``, one-line ``summary`` and ``options`` (a list of
    dicts ``name``, ``type``, ``default``, ``meaning``: the table of docs/integrators.md)."""
    return _lodestar.integrators()


def read_exr(path: Union[str, "os.PathLike[str]"]) -> np.ndarray:
    """An EXR image (its RGB channels) as a float32 array H x W x 3."""
    return _lodestar.read_exr(os.fspath(path))


def write_exr(path: Union[str, "os.PathLike[str]"], image: np.ndarray) -> None:
    """Write an H x W x 3 array as a float32 EXR (atomically)."""
    _lodestar.write_exr(os.fspath(path), _rgb(image, "image"))


def _rgb(a: np.ndarray, name: str) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"{name}: expected an array H x W x 3, got shape {a.shape}")
    return a
