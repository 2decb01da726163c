"""Type stubs of the wavetrace package (its native module is written in Rust: src/python.rs)."""

from os import PathLike
from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, "PathLike[str]"]

class WavetraceError(Exception):
    """A scene that cannot load, a render that fails, a bad argument; the message names the
    file and the problem (the JSON path of the object in the file)."""

class Render:
    """One render."""

    image: npt.NDArray[np.float32]
    """H x W x 3 linear radiance: the mean of each pixel's samples, row 0 at the top."""
    variance: npt.NDArray[np.float32]
    """H x W x 3 variance of that mean."""
    layers: Dict[str, npt.NDArray[Any]]
    """The AOV layers asked for, by name: H x W x 3 (albedo, normal, position, emission),
    H x W x 2 (uv), H x W float32 (depth, alpha) or uint32 (material, instance)."""
    stats: Dict[str, Any]
    """seconds, samples, samples_per_second, rays_per_second, extension_rays, shadow_rays,
    dropped, device."""

class Scene:
    """A glTF scene loaded and prepared for tracing once, to render many times."""

    def __init__(
        self, path: _Path, *, camera: Optional[str] = None, env: Optional[str] = None
    ) -> None:
        """``camera``: an index or name; ``env``: None (the built-in studio for a file without
        lights), "studio", "none" or an .hdr/.exr map."""
    @property
    def path(self) -> str: ...
    def render(
        self,
        *,
        width: Optional[int] = None,
        height: Optional[int] = None,
        spp: int = 64,
        seed: int = 0,
        max_depth: int = 8,
        device: str = "auto",
        aov: Sequence[str] = (),
        progress: Optional[Callable[[int, int], None]] = None,
    ) -> Render:
        """Renders on ``device`` ("auto", "gpu", "cpu"); ``progress(done, total)`` gets the
        samples done about ten times a second. The GIL is released while it runs."""

def render(
    path: _Path,
    *,
    camera: Optional[str] = None,
    env: Optional[str] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    spp: int = 64,
    seed: int = 0,
    max_depth: int = 8,
    device: str = "auto",
    aov: Sequence[str] = (),
    progress: Optional[Callable[[int, int], None]] = None,
) -> Render:
    """``Scene(path, camera=camera, env=env).render(...)``."""

class Verdict:
    """The per-tile Welch test's verdict; true where the images agree."""

    passed: bool
    tests: int
    """Tile x channel tests."""
    failures: int
    """Tests that reject equal expectations (family-wise level alpha, Sidak-corrected)."""
    min_p: float
    relative_mse: float
    """Of the first image against the second."""
    summary: str
    def __bool__(self) -> bool: ...

def compare(a: _Path, b: _Path, *, tile: int = 8, alpha: float = 0.01) -> Verdict:
    """The per-tile Welch test of two wavetrace EXRs, as `wavetrace compare` runs it."""

def verify(
    path: _Path,
    *,
    camera: Optional[str] = None,
    env: Optional[str] = None,
    width: Optional[int] = 64,
    height: Optional[int] = None,
    spp: int = 256,
    seed: int = 0,
    max_depth: int = 8,
    tile: int = 8,
    alpha: float = 0.01,
) -> Verdict:
    """The scene on the GPU (seed) and with the CPU reference (seed + 1), tested per tile."""

def read_exr(
    path: _Path,
) -> Tuple[npt.NDArray[np.float32], Optional[npt.NDArray[np.float32]]]:
    """The mean (H x W x 3) and, where present, the variance of the mean of a wavetrace EXR."""
