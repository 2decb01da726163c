"""The Python package (issue 60, item 1): its arrays are the command line's EXR bit for bit, a
bad file raises WavetraceError with the file's JSON path, a Scene renders many times, layers and
progress come back, compare and verify judge the GPU against the CPU reference. Run by .ci/run in a fresh venv after `pip install .`:

    python -m pytest tests/python

The command line's binary is WAVETRACE_BIN, or target/release/wavetrace.
"""

import os
import subprocess
import tempfile

import numpy as np
import pytest
import wavetrace

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CORNELL = os.path.join(ROOT, "scenes", "cornell-box.gltf")
BIN = os.environ.get("WAVETRACE_BIN", os.path.join(ROOT, "target", "release", "wavetrace"))
GPU = os.environ.get("WAVETRACE_SKIP_GPU") != "1"


def test_the_array_is_the_command_lines_exr_bit_for_bit(tmp_path):
    exr = tmp_path / "cornell.exr"
    subprocess.run(
        [BIN, "render", CORNELL, "--device", "cpu", "--width", "32", "--height", "24",
         "--spp", "8", "--seed", "3", "--quiet", "-o", str(exr)],
        check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    r = wavetrace.render(CORNELL, width=32, height=24, spp=8, seed=3, device="cpu")
    mean, variance = wavetrace.read_exr(exr)
    assert r.image.shape == (24, 32, 3) and r.image.dtype == np.float32
    assert np.array_equal(r.image.view(np.uint32), mean.view(np.uint32))
    assert np.array_equal(r.variance.view(np.uint32), variance.view(np.uint32))
    assert r.stats["samples"] == 32 * 24 * 8 and r.stats["samples_per_second"] > 0


def test_a_bad_file_raises_with_its_json_path(tmp_path):
    bad = tmp_path / "bad.gltf"
    bad.write_text('{"asset": {"version": "2.0"}, "scenes": [{"nodes": [7]}]}')
    with pytest.raises(wavetrace.WavetraceError, match=r"bad\.gltf.*nodes"):
        wavetrace.Scene(bad)
    with pytest.raises(wavetrace.WavetraceError, match="no-such.gltf"):
        wavetrace.render(tmp_path / "no-such.gltf")
    with pytest.raises(wavetrace.WavetraceError, match="aov"):
        wavetrace.render(CORNELL, width=8, spp=1, device="cpu", aov=["shine"])


def test_a_scene_renders_many_times():
    scene = wavetrace.Scene(CORNELL)
    a = scene.render(width=16, height=16, spp=4, device="cpu")
    b = scene.render(width=16, height=16, spp=4, device="cpu")
    c = scene.render(width=16, height=16, spp=4, seed=1, device="cpu")
    assert np.array_equal(a.image, b.image)
    assert not np.array_equal(a.image, c.image)
    # A wider image through the same camera, and its layers.
    d = scene.render(width=24, height=16, spp=4, device="cpu",
                     aov=["albedo", "normal", "depth", "material"])
    assert d.image.shape == (16, 24, 3)
    assert d.layers["albedo"].shape == (16, 24, 3)
    # (The wider image sees past the box's sides: its middle is all box.)
    middle = (slice(2, 14), slice(6, 18))
    assert d.layers["depth"].shape == (16, 24) and (d.layers["depth"][middle] > 0).all()
    assert d.layers["material"].dtype == np.uint32 and (d.layers["material"][middle] >= 1).all()
    assert (d.layers["depth"] == 0).any(), "no ray escapes past the box's sides"
    # Raw normals: unit inside a face, shorter where a pixel's samples straddle an edge.
    lengths = np.linalg.norm(d.layers["normal"], axis=2)
    assert lengths.max() <= 1 + 1e-5 and np.median(lengths[middle]) == pytest.approx(1, abs=1e-5)


def test_progress_is_reported_and_the_gpu_renders():
    seen = []
    r = wavetrace.render(CORNELL, width=64, spp=16, device="cpu",
                         progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1] == (64 * 64 * 16, 64 * 64 * 16)
    assert all(d1 <= d2 for (d1, _), (d2, _) in zip(seen, seen[1:]))
    if not GPU:
        pytest.skip("WAVETRACE_SKIP_GPU=1")
    g = wavetrace.render(CORNELL, width=64, spp=16, device="gpu")
    assert np.isfinite(g.image).all() and g.image.mean() > 0
    # The GPU and the CPU: the same expectation, independent seeds, tested per tile.
    with tempfile.TemporaryDirectory() as d:
        ea, eb = os.path.join(d, "gpu.exr"), os.path.join(d, "cpu.exr")
        for device, seed, out in [("gpu", "0", ea), ("cpu", "1", eb)]:
            subprocess.run([BIN, "render", CORNELL, "--device", device, "--width", "32",
                            "--spp", "64", "--seed", seed, "--quiet", "-o", out],
                           check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
        verdict = wavetrace.compare(ea, eb)
        assert verdict and verdict.tests > 0, verdict.summary
    # The same through verify: one scene, GPU against the CPU reference.
    v = wavetrace.verify(CORNELL, width=32, spp=64)
    assert isinstance(v, wavetrace.Verdict) and v.passed, v.summary
