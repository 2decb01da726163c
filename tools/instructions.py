#!/usr/bin/env python3
"""Instructions per sample of the CPU reference (and of Mitsuba 3's scalar_rgb on the same
render), counted by valgrind's callgrind: a figure this machine's drifting clock cannot move,
for changes too small for `tools/ab_bench.py`'s pairs to see, and the cost model of the CPU side
(`docs/performance.md`).

Each program renders the scene twice on one thread (RAYON_NUM_THREADS=1; Mitsuba through
`tools/mitsuba_bench.py --threads 1`) at two sample counts, and the difference of the two runs'
instructions over the difference of their samples is the cost of a sample: loading, the BVH
build, start-up and writing the image cancel. For wavetrace the same difference is taken of the
inclusive instructions of the functions a sample runs through (the closest-hit and shadow walks,
the BSDF frame and its queries, the light BVH, the camera ray, the hit's surface and material), each per
sample, with the rays per sample from `render`'s own count.

    tools/instructions.py target/release/wavetrace [/tmp/before/wavetrace ...] [--mitsuba]
        [--scene scenes/cornell-box.gltf] [--size 64] [--spp 16 48] [-- RENDER OPTIONS]

`--mitsuba` adds Mitsuba's scalar_rgb (the mitsuba wheel; tools/mitsuba_bench.py converts the
scene, which must be exactly Lambertian). Render options after `--` go to every wavetrace
render, e.g. `-- --sampler independent --light-sampler power`, which samples the Cornell box as
Mitsuba's path tracer does (the same estimator). A run takes about a second per 1 000 samples.
`--device gpu` counts the wavefront kernels on lavapipe instead (`render --device gpu`, which
must choose it): llvmpipe's JIT-compiled kernels run under callgrind (`--smc-check=all`, which
code generated at run time needs) with one worker thread (`LP_NUM_THREADS=1`, so that no thread
spins while another works), after one uncounted run under valgrind that leaves every kernel in
Mesa's shader cache (valgrind's virtual CPU has fewer features than this one, and the cache's
keys name them: a native run's entries would not be found), so the two counted runs load the
same compiled code. The count is the kernels' and the
driver's together, per sample; callgrind cannot name the JIT's functions, so there is no
breakdown. Two counts of the same build agree to a few parts per million (this machine's
lavapipe render takes 2 minutes under callgrind at the default size, most of it creating the
pipelines, which cancels).

Python 3 standard library, valgrind and callgrind_annotate.
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

# What a wavetrace sample runs through: (label, function name as callgrind_annotate prints it, or
# names in turn, the first one a build has out of line counting).
FUNCTIONS = (
    # The scene's walks: tlas.rs's, or since 5 December 2026, which inlines those, `PreparedScene`'s
    # methods around them (the same walks and their alpha tests).
    (
        "closest-hit walk",
        ("wavetrace::tlas::scene_intersect_closest", "wavetrace::render::PreparedScene::intersect_closest"),
    ),
    (
        "shadow walk",
        ("wavetrace::tlas::scene_intersect_any", "wavetrace::render::PreparedScene::intersect_any"),
    ),
    ("BSDF frame", "wavetrace::bsdf::BsdfFrame::new_shading"),
    ("BSDF sample", "wavetrace::bsdf::BsdfFrame::sample"),
    ("BSDF eval", "wavetrace::bsdf::BsdfFrame::eval"),
    ("BSDF pdf", "wavetrace::bsdf::BsdfFrame::pdf"),
    ("plain diffuse frame", "wavetrace::bsdf::LambertFrame::new"),
    ("plain diffuse sample", "wavetrace::bsdf::LambertFrame::sample"),
    ("light BVH", "wavetrace::light_bvh::light_bvh_walk"),
    ("emitter sample", "wavetrace::cpu::path::sample_emitter"),
    ("camera ray", "wavetrace::cpu::path::primary_ray"),
    ("hit surface", "wavetrace::render::PreparedScene::hit_surface"),
    ("surface material", "wavetrace::surface::surface_material"),
)
PATH = "wavetrace::cpu::path::trace_path_matching"

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def callgrind(cmd, env, out, jit=False):
    """Runs cmd under callgrind; returns (total instructions, the program's output). `jit`: the
    program runs code it generates (llvmpipe's kernels), which callgrind must check for."""
    smc = ["--smc-check=all"] if jit else []
    run = subprocess.run(
        ["valgrind", "--tool=callgrind", *smc, f"--callgrind-out-file={out}", *cmd],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    if run.returncode != 0:
        sys.exit(f"instructions: {' '.join(cmd)} failed ({run.returncode}):\n{run.stdout[-2000:]}")
    with open(out) as f:
        for line in f:
            if line.startswith(("summary:", "totals:")):
                return int(line.split()[1]), run.stdout
    sys.exit(f"instructions: no totals in {out}")


def inclusive(out):
    """Inclusive instructions per function of a callgrind file (the function's own entry). Run
    outside the source tree: inside it callgrind_annotate splits a function by the source files
    it finds there, and the function's own entry keeps only part of its cost."""
    text = subprocess.run(
        ["callgrind_annotate", "--inclusive=yes", "--threshold=100", out],
        cwd=os.path.dirname(os.path.abspath(out)),
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        check=True,
    ).stdout
    costs = {}
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+) \([^)]*\)\s+\S*?:(\S.*?) \[[^\]]*\]$", line)
        if m:
            name = m.group(2)
            costs.setdefault(name, int(m.group(1).replace(",", "")))
    return costs


def wavetrace(binary, args, spp, folder, tag):
    gpu = args.device == "gpu"
    env = dict(os.environ, RAYON_NUM_THREADS="1", LP_NUM_THREADS="1")
    command = lambda s: [
        binary, "render", args.scene, "--device", args.device, "--spp", str(s),
        "--width", str(args.size), "--height", str(args.size),
        "-o", os.path.join(folder, f"{tag}-{s}.exr"), *args.render,
    ]
    if gpu:
        # Uncounted: the kernels compiled once and kept in Mesa's shader cache for both counts.
        # Under valgrind too (its tool "none", which only runs the program): valgrind's virtual
        # CPU lacks some of this machine's features, the cache's keys name them, and so a
        # native run's entries are not the ones a run under callgrind looks up.
        subprocess.run(
            ["valgrind", "--tool=none", "--smc-check=all", *command(1)],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
    runs = []
    for s in spp:
        out = os.path.join(folder, f"{tag}-{s}.out")
        cmd = command(s)
        total, text = callgrind(cmd, env, out, jit=gpu)
        m = re.search(r"\((\d+) extension \+ (\d+) shadow rays\)", text)
        if not m:
            sys.exit(f"instructions: no ray counts in the output of {' '.join(cmd)}")
        runs.append((total, int(m.group(1)), int(m.group(2)), {} if gpu else inclusive(out)))
    return runs


def mitsuba(args, spp, folder):
    totals = []
    for s in spp:
        cmd = [
            sys.executable, os.path.join(ROOT, "tools", "mitsuba_bench.py"), args.scene,
            "--width", str(args.size), "--height", str(args.size), "--spp", str(s),
            "--threads", "1",
        ]
        total, _ = callgrind(cmd, dict(os.environ), os.path.join(folder, f"mitsuba-{s}.out"))
        totals.append(total)
    return totals


def split_render_options(argv):
    """The tool's own arguments and the render options after `--` (also tools/jit_profile.py)."""
    if "--" in argv:
        at = argv.index("--")
        return argv[:at], argv[at + 1:]
    return argv, []


def main():
    argv, render = split_render_options(sys.argv[1:])
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("binaries", nargs="+", help="wavetrace binaries")
    ap.add_argument("--scene", default=os.path.join(ROOT, "scenes", "cornell-box.gltf"))
    ap.add_argument("--size", type=int, default=64, help="image width and height")
    ap.add_argument("--spp", type=int, nargs=2, default=[16, 48], metavar=("LOW", "HIGH"))
    ap.add_argument("--mitsuba", action="store_true", help="add Mitsuba 3's scalar_rgb")
    ap.add_argument(
        "--device", choices=("cpu", "gpu"), default="cpu",
        help="the CPU reference (default) or the wavefront kernels on lavapipe",
    )
    args = ap.parse_args(argv)
    args.render = render
    low, high = args.spp
    if not 0 < low < high:
        sys.exit("instructions: --spp LOW HIGH with 0 < LOW < HIGH")
    samples = (high - low) * args.size * args.size

    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for k, binary in enumerate(args.binaries):
            (t0, e0, s0, f0), (t1, e1, s1, f1) = wavetrace(binary, args, (low, high), folder, f"w{k}")
            per = lambda a, b: (b - a) / samples
            def counted(names):
                names = (names,) if isinstance(names, str) else names
                name = next((n for n in names if f1.get(n, 0) > 0), names[0])
                return per(f0.get(name, 0), f1.get(name, 0))

            parts = [(label, counted(names)) for label, names in FUNCTIONS]
            path = per(f0.get(PATH, 0), f1.get(PATH, 0))
            # The path loop's own work: what its callees listed above do not account for (the
            # light BVH is called from inside the emitter sampling, which is inlined).
            parts.append(("rest of the path loop", path - sum(v for _, v in parts)))
            if args.device == "gpu":
                parts = []
            rows.append((binary, per(t0, t1), per(e0, e1), per(s0, s1), parts))
        reference = None
        if args.mitsuba:
            m0, m1 = mitsuba(args, (low, high), folder)
            reference = (m1 - m0) / samples

    print(
        f"instructions per sample, {os.path.basename(args.scene)} at {args.size}², the runs at "
        f"{low} and {high} spp differenced, one thread"
        + (", on lavapipe" if args.device == "gpu" else "")
        + (f", render options: {' '.join(args.render)}" if args.render else "")
    )
    for binary, total, ext, shadow, parts in rows:
        print(f"\n{binary}: {total:,.0f} per sample ({ext:.3f} extension + {shadow:.3f} shadow rays)")
        if reference:
            print(f"  against Mitsuba scalar_rgb's {reference:,.0f}: {total / reference:.2f}×")
        for label, value in parts:
            print(f"  {label:<24} {value:>9,.0f}  {value / total * 100:5.1f} %")
    if reference and not rows:
        print(f"Mitsuba scalar_rgb: {reference:,.0f} per sample")


if __name__ == "__main__":
    main()
