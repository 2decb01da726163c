#!/usr/bin/env python3
"""The speed targets' ratios side by side: an earlier wavetrace build against a later one on the
Cornell box (the GPU and CPU rows of `wavetrace bench`), Mitsuba 3's scalar_rgb on the same
render (`tools/mitsuba_bench.py`, where the mitsuba wheel is installed) with the later build's CPU
reference sampling as Mitsuba does (`bench --cpu-only --sampler independent --light-sampler
power`: independent samples, the one emitting quad picked with probability 1 and sampled by area,
so the two run the same estimator), and the BVH build of a large scene as a render's one build
pays for it (`render`'s "built in", a fresh process each).

This machine's speed drifts by more than most changes make, so the programs run in rounds whose
order alternates (earlier, later, Mitsuba, builds; then the reverse), and each ratio is taken
within a round: the table gives its median and range over the rounds. Each build's bench runs
once untimed before the rounds (lavapipe's first run of a build compiles part of its kernels).

    cargo build --release
    git worktree add /tmp/before 26cccc5 && (cd /tmp/before && cargo build --release)
    python3 tools/gen_large.py terrain --triangles 1000000 /tmp/terrain-1000000.gltf
    tools/issue_targets.py /tmp/before/target/release/wavetrace target/release/wavetrace \\
        --rounds 6 --terrain /tmp/terrain-1000000.gltf --earlier-gpu 0.66 --earlier-build 444

The issue's absolute targets (1.0 M samples/s on lavapipe, 60 ms per million triangles) were
set on this machine as it ran that day, when the earlier build did 0.66 M samples/s and 444 ms;
`--earlier-gpu` and `--earlier-build` give the later build's figures at that speed of the
machine (its ratio to the earlier build, measured in the same round, times the earlier build's
figure of that day), since the machine's speed drifts by more than the targets' margins.

Arguments after the two binaries and the script's own options go to `wavetrace bench` as they
are (default: the Cornell box, `bench`'s 256², 16 spp, depth 8). It reads the text table `bench`
has printed since before `--json` existed, so any build since November 2026 can be the earlier
one; the rows present in every round are tabled. Python 3 standard library only.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def bench(binary, bench_args):
    """M samples/s of the first scene's GPU and CPU rows of `bench BENCH_ARGS`."""
    done = subprocess.run([binary, "bench", *bench_args], capture_output=True, text=True, cwd=ROOT)
    rows = {}
    for line in done.stdout.splitlines():
        m = re.match(r"(\S+)\s+(gpu|cpu)\s+[\d.]+\s+([\d.]+)", line)
        if m and m.group(2) not in rows:
            rows[m.group(2)] = float(m.group(3))
    if done.returncode != 0 or not rows:
        sys.exit(f"issue_targets: {binary} bench printed no rows:\n{done.stderr.strip()}")
    return rows


def mitsuba(scene):
    done = subprocess.run(
        [sys.executable, os.path.join(ROOT, "tools", "mitsuba_bench.py"), scene],
        capture_output=True,
        text=True,
    )
    m = re.search(r"([\d.]+) M samples/s", done.stdout)
    return float(m.group(1)) if m else None


def build_ms(binary, scene, out):
    """The BVH build time `render` reports for SCENE (one build in a fresh process)."""
    done = subprocess.run(
        [binary, "render", scene, "--device", "cpu", "--spp", "1", "--width", "8",
         "--height", "8", "-o", out],
        capture_output=True,
        text=True,
    )
    m = re.search(r"built in ([\d.]+) ms", done.stdout + done.stderr)
    if not m:
        sys.exit(f"issue_targets: {binary} render {scene}: no build time:\n{done.stderr.strip()}")
    return float(m.group(1))


def spread(xs):
    return f"{statistics.median(xs):.3f} ({min(xs):.3f}–{max(xs):.3f})"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("earlier", help="the earlier build's wavetrace binary")
    parser.add_argument("later", help="the later build's wavetrace binary")
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--terrain", help="a large scene whose BVH build is timed")
    parser.add_argument("--no-mitsuba", action="store_true")
    parser.add_argument(
        "--earlier-gpu", type=float, metavar="M",
        help="the earlier build's GPU M samples/s as measured when its target was set (issue "
             "13: 0.66): the later build's figure is also given at that speed of the machine, "
             "its ratio to the earlier build in a round times M")
    parser.add_argument(
        "--earlier-build", type=float, metavar="MS",
        help="the earlier build's BVH build ms as measured when its target was set (issue 13: "
             "444): the later build's is also given at that speed, MS over the round's ratio")
    args, bench_args = parser.parse_known_args()
    scenes = [a for a in bench_args if a.endswith((".gltf", ".glb"))]
    if not scenes:
        scenes = [os.path.join(ROOT, "scenes", "cornell-box.gltf")]
        bench_args.append(scenes[0])
    out = os.path.join(tempfile.mkdtemp(), "t.png")
    steps = [
        ("earlier", lambda: bench(args.earlier, bench_args)),
        ("later", lambda: bench(args.later, bench_args)),
    ]
    if not args.no_mitsuba:
        steps.append(("mitsuba", lambda: mitsuba(scenes[0])))
        as_mitsuba = ["--cpu-only", "--sampler", "independent", "--light-sampler", "power"]
        steps.append(("later as mitsuba", lambda: bench(args.later, bench_args + as_mitsuba)))
    if args.terrain:
        steps.append(("earlier build", lambda: build_ms(args.earlier, args.terrain, out)))
        steps.append(("later build", lambda: build_ms(args.later, args.terrain, out)))
    # One untimed bench of each build first: lavapipe compiles part of a kernel at its first
    # dispatch and caches it, so a build's first run is slower (docs/perf-log/2026-12-02-lavapipe-scene-reads.md).
    for binary in (args.earlier, args.later):
        bench(binary, bench_args)
    rounds = []
    for r in range(args.rounds):
        order = steps if r % 2 == 0 else steps[::-1]
        rounds.append({name: run() for name, run in order})
        print(f"round {r + 1} of {args.rounds}: {rounds[-1]}", file=sys.stderr)

    def column(f):
        return spread([f(x) for x in rounds])

    print(f"{args.rounds} rounds in alternating order; median (range) of per-round figures\n")
    print("| figure | value |\n|---|---|")
    devices = [d for d in ("gpu", "cpu") if all(d in x["earlier"] and d in x["later"] for x in rounds)]
    for device in devices:
        print(f"| {device} M samples/s, earlier | {column(lambda x: x['earlier'][device])} |")
        print(f"| {device} M samples/s, later | {column(lambda x: x['later'][device])} |")
        print(f"| {device} later / earlier | "
              f"{column(lambda x: x['later'][device] / x['earlier'][device])} |")
        if device == "gpu" and args.earlier_gpu:
            print(f"| gpu M samples/s, later, with the earlier at {args.earlier_gpu} | "
                  f"{column(lambda x: args.earlier_gpu * x['later'][device] / x['earlier'][device])} |")
    if devices == ["gpu", "cpu"]:
        print(f"| later gpu / later cpu | {column(lambda x: x['later']['gpu'] / x['later']['cpu'])} |")
    if not args.no_mitsuba and "cpu" in devices and all(x["mitsuba"] for x in rounds):
        print(f"| Mitsuba scalar_rgb M samples/s | {column(lambda x: x['mitsuba'])} |")
        print(f"| later cpu / Mitsuba | {column(lambda x: x['later']['cpu'] / x['mitsuba'])} |")
        print(f"| later cpu sampling as Mitsuba, M samples/s | "
              f"{column(lambda x: x['later as mitsuba']['cpu'])} |")
        print(f"| later cpu sampling as Mitsuba / Mitsuba | "
              f"{column(lambda x: x['later as mitsuba']['cpu'] / x['mitsuba'])} |")
    if args.terrain:
        print(f"| BVH build ms, earlier | {column(lambda x: x['earlier build'])} |")
        print(f"| BVH build ms, later | {column(lambda x: x['later build'])} |")
        print(f"| BVH build earlier / later | "
              f"{column(lambda x: x['earlier build'] / x['later build'])} |")
        if args.earlier_build:
            print(f"| BVH build ms, later, with the earlier at {args.earlier_build} | "
                  f"{column(lambda x: args.earlier_build * x['later build'] / x['earlier build'])} |")


if __name__ == "__main__":
    main()
