#!/usr/bin/env python3
"""Compare two wavetrace builds side by side: `wavetrace bench` of each, in ABBA order.

This machine's speed drifts by 15 % and more over minutes, so a build that always runs second
can look faster or slower than it is. Runs here come in pairs whose order alternates (A B, B A,
A B, ...); each pair gives the ratio B / A of samples per second per scene and device, and the
table reports the median pair ratio with its range, and for the GPU the median time of extend,
shade and connect with shade's and connect's against extend's in the same run (ratios the drift
cancels from, for changes to one kernel).

    tools/ab_bench.py /tmp/wt-before /tmp/wt-after --pairs 6 --gpu-only scenes/cornell-box.gltf

Arguments after the two binaries and the script's own options go to `wavetrace bench` as they
are (scenes, --spp, --gpu-only, --cpu-only, ...).

Each build first runs once untimed (`--warm-up 0` leaves that out): lavapipe compiles parts of a
kernel at its first dispatch and keeps them in Mesa's shader cache, so a build's first run on a
scene could take seconds longer in one kernel (5 December 2026: prism's shade 913 ms against 147
in a build's first pair, 129 after). `bench` now renders each scene once untimed itself before
its GPU row (docs/performance.md, "wavetrace bench"), so this run only settles the files and caches both builds
read.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile


# The kernels tabled, extend first: the others are shown against it as well.
KERNELS = ("extend", "shade", "connect")


def bench(binary, bench_args, out):
    cmd = [binary, "bench", "--json", out, *bench_args]
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"ab_bench: {' '.join(cmd)} failed ({done.returncode}):\n{done.stderr.strip()}")
    with open(out) as f:
        return {(row["scene"], row["device"]): row for row in json.load(f)["rows"]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("a", help="the reference build's wavetrace binary")
    parser.add_argument("b", help="the build to compare with it")
    parser.add_argument("--pairs", type=int, default=4, help="pairs of runs (default 4)")
    parser.add_argument("--warm-up", type=int, default=1, choices=(0, 1),
                        help="an untimed run of each build first (default 1)")
    args, bench_args = parser.parse_known_args()
    if args.pairs < 1:
        parser.error("--pairs must be at least 1")
    for binary in (args.a, args.b):
        if not os.access(binary, os.X_OK):
            parser.error(f"{binary} is not an executable file")

    ratios, kernels = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        if args.warm_up:
            for name, binary in (("a", args.a), ("b", args.b)):
                bench(binary, bench_args, os.path.join(tmp, f"warm-{name}.json"))
            print("warm-up runs done", file=sys.stderr)
        for p in range(args.pairs):
            order = [("a", args.a), ("b", args.b)]
            if p % 2:
                order.reverse()
            runs = {name: bench(binary, bench_args, os.path.join(tmp, f"{name}{p}.json"))
                    for name, binary in order}
            for key, row_b in runs["b"].items():
                row_a = runs["a"].get(key)
                if row_a is None or row_a["samples_per_second"] <= 0:
                    continue
                ratios.setdefault(key, []).append(
                    row_b["samples_per_second"] / row_a["samples_per_second"])
                for name, row in (("a", row_a), ("b", row_b)):
                    kernel_ms = row.get("kernel_ms") or {}
                    for kernel in KERNELS:
                        if kernel in kernel_ms:
                            kernels.setdefault((key, name, kernel), []).append(kernel_ms[kernel])
            print(f"pair {p + 1} of {args.pairs} done", file=sys.stderr)

    print(f"B = {args.b} against A = {args.a}: {args.pairs} pairs in ABBA order\n")
    print("| scene | device | B / A samples/s: median (range) | kernels, median ms A → B (against extend) |")
    print("|---|---|---|---|")
    for (scene, device), r in sorted(ratios.items()):
        parts = []
        names = [k for k in KERNELS
                 if ((scene, device), "a", k) in kernels and ((scene, device), "b", k) in kernels]
        extend = {n: statistics.median(kernels.get(((scene, device), n, "extend"), [0]))
                  for n in ("a", "b")}
        for kernel in names:
            ms = {n: statistics.median(kernels[((scene, device), n, kernel)]) for n in ("a", "b")}
            rel = ""
            if kernel != "extend" and extend["a"] > 0 and extend["b"] > 0:
                rel = f" ({ms['a'] / extend['a']:.3f} → {ms['b'] / extend['b']:.3f})"
            parts.append(f"{kernel} {ms['a']:.0f} → {ms['b']:.0f}{rel}")
        print(f"| {scene} | {device} | {statistics.median(r):.3f} ({min(r):.3f}–{max(r):.3f}) "
              f"| {', '.join(parts)} |")


if __name__ == "__main__":
    main()
