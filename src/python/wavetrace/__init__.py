"""wavetrace: a headless GPU wavefront path tracer (Vulkan) with a CPU reference integrator.

    import wavetrace
    r = wavetrace.render("scene.glb", width=256, spp=64)   # numpy float32, H x W x 3
    r.image, r.variance, r.layers, r.stats

    scene = wavetrace.Scene("scene.glb")                     # loaded and prepared once
    a = scene.render(spp=16, device="cpu")
    b = scene.render(spp=16, device="gpu", aov=["albedo", "normal"])

Images are linear radiance, the mean of each pixel's samples, row 0 at the top. Errors are
``wavetrace.WavetraceError`` with the message the command line prints. docs/python.md.
"""

from ._native import (
    Render,
    Scene,
    Verdict,
    WavetraceError,
    __version__,
    compare,
    read_exr,
    render,
    verify,
)

__all__ = [
    "Render",
    "Scene",
    "Verdict",
    "WavetraceError",
    "__version__",
    "compare",
    "read_exr",
    "render",
    "verify",
]
