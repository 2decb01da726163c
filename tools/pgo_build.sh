#!/usr/bin/env bash
# A profile-guided build of wavetrace (rustc's PGO: -Cprofile-generate, a training run,
# -Cprofile-use), for CPU renders: the CPU integrators run faster than in the plain release
# build (docs/perf-log/2026-12-02-cpu-reference-against-mitsuba.md has the figures), to the same images bit for bit (PGO changes
# how the compiler lays out, inlines and orders code, not the floating-point operations). The
# GPU path and the BVH build measured the same.
#
#   tools/pgo_build.sh [SCENE ...]   builds target/pgo/release/wavetrace in about twice a release
#                                    build's time (an instrumented build, training, the final build)
#
# The training renders on the CPU every committed scene with the path tracer (Sobol and the
# independent sampler), BDPT and light tracing, and builds the BVH of a generated 100k-triangle
# terrain; then the models of ../shared/gltf-samples where that folder is present
# (WAVETRACE_SAMPLES names another), and every SCENE given, each under a uniform environment.
# Code the training does not run is laid out as cold: a build trained on the committed scenes
# alone, which have no textures, rendered DamagedHelmet at 0.77 of the plain build's speed, so
# name scenes like those you render. The profile is kept under target/pgo-data/. Needs the
# toolchain's own llvm-profdata: the rustup component llvm-tools, which the script adds when it
# is missing (rustup must reach its distribution server). target/release is left as it is.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

host=$(rustc -vV | sed -n 's/^host: //p')
profdata="$(rustc --print sysroot)/lib/rustlib/$host/bin/llvm-profdata"
if [ ! -x "$profdata" ]; then
    echo "pgo_build: adding the rustup component llvm-tools (for llvm-profdata)"
    rustup component add llvm-tools
fi
[ -x "$profdata" ] || { echo "pgo_build: no llvm-profdata at $profdata" >&2; exit 1; }

data="$root/target/pgo-data"
rm -rf "$data" && mkdir -p "$data/raw"

echo "pgo_build: 1/3 the instrumented build (target/pgo-generate)"
RUSTFLAGS="-Cprofile-generate=$data/raw" \
    cargo build --release --locked --bin wavetrace --target-dir target/pgo-generate
trainee="$root/target/pgo-generate/release/wavetrace"

echo "pgo_build: 2/3 the training renders"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# (A render's notes, such as dropped degenerate triangles, are shown only if it fails.)
render() {
    "$trainee" render "$@" --device cpu -o "$out/image.exr" >/dev/null 2>"$out/log" ||
        { cat "$out/log" >&2 && return 1; }
}
for scene in scenes/*.gltf; do
    render "$scene" --width 96 --height 96 --spp 16
done
render scenes/cornell-box.gltf --width 96 --height 96 --spp 16 --sampler independent --light-sampler power
render scenes/cornell-box.gltf --width 64 --height 64 --spp 8 --integrator bdpt
render scenes/caustic.gltf --width 64 --height 64 --spp 8 --integrator light
samples="${WAVETRACE_SAMPLES:-$root/../shared/gltf-samples}"
models=()
if [ -d "$samples/valid" ]; then
    models+=("$samples"/valid/*.glb "$samples"/valid/extensions/*.glb)
else
    echo "pgo_build: notice: $samples is absent; training on the committed scenes and those named"
fi
for scene in "${models[@]}" "$@"; do
    render "$scene" --width 96 --height 96 --spp 8 --environment 1
done
if [ -f "$samples/env/studio_small_03_1k.hdr" ] && [ -f "$samples/valid/DamagedHelmet.glb" ]; then
    render "$samples/valid/DamagedHelmet.glb" --width 96 --height 96 --spp 16 \
        --env "$samples/env/studio_small_03_1k.hdr"
fi
python3 tools/gen_large.py terrain --triangles 100000 "$out/terrain.gltf" >/dev/null 2>&1
"$trainee" bench --bvh --cpu-only "$out/terrain.gltf" --builds 3 >/dev/null
"$profdata" merge -o "$data/wavetrace.profdata" "$data/raw"

echo "pgo_build: 3/3 the build that uses the profile (target/pgo)"
RUSTFLAGS="-Cprofile-use=$data/wavetrace.profdata" \
    cargo build --release --locked --bin wavetrace --target-dir target/pgo
echo "pgo_build: target/pgo/release/wavetrace"
