#!/usr/bin/env bash
# The real-GPU figures issue 13 asks for, as one prepared run of the project's `device` tool (a
# lent machine with one NVIDIA H100 or H200, its Vulkan driver, no Rust and no network, and
# 15 minutes of device time per session, start-up included), so a session that is lent one
# spends it measuring rather than setting up.
#
#   tools/device_check.sh prepare [--mitsuba]    here: fills .device/ and .gl/ (both ignored)
#   run(command="bash tools/device_check.sh run", carry=[".device", ".gl"], timeout_s=540)
#   tools/device_check.sh run --quick            here, on lavapipe: the same steps, small
#                                                (PYTHON=python3.12 for the Mitsuba step)
#
# `prepare` builds the release binary and puts a stripped copy in .device/, with the two
# Khronos sample models the issue names read from ../shared/gltf-samples (third-party data:
# copied into the ignored .device/ for the trip, never committed), the Vulkan loader packages
# the device README names in .gl/, and with --mitsuba Mitsuba 3 and Dr.Jit (Python 3.12 wheels,
# trimmed to the scalar_rgb and cuda_ad_rgb variants and compressed) in .device/site.tar.xz,
# under the tool's 64 MiB limit on what travels.
#
# `run` writes under $OUT (the tool brings back at most 8 files): device_check.log (every
# step's output, its wall time and exit status), bench-cornell.json and bench-large.json
# (`wavetrace bench --json`) and cornell-box.png. A step that fails or runs past its time is
# logged and the next one runs. The steps:
#   1. nvidia-smi, and `render --device auto` of the Cornell box: it must say it chose the GPU;
#   2. `verify scenes/*.gltf` as CI runs it: the GPU against the CPU reference, every scene;
#   3. `bench --gpu-only` of the Cornell box (1024², 64 spp, depth 8): samples/s, rays/s and
#      per-kernel ms, as on lavapipe but wide;
#   4. `bench --gpu-only --environment 1` of TransmissionTest (129k triangles),
#      MetalRoughSpheresNoTextures (1M) and a 2M-triangle terrain (tools/gen_large.py): the
#      issue's ≥ 1 G rays/s (extension + shadow; the uniform environment gives the unlit spheres
#      shadow rays);
#   5. `bench --bvh` of the two large scenes on the machine's 16 cores;
#   6. with .device/site.tar.xz: Mitsuba 3's cuda_ad_rgb on the Cornell box at step 3's settings
#      (tools/mitsuba_bench.py, independent sampler on both sides), then wavetrace the same way.
set -uo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root" || exit 2
samples="${WAVETRACE_SAMPLES:-$root/../shared/gltf-samples}"
large=(TransmissionTest.glb MetalRoughSpheresNoTextures.glb)

prepare() {
    local mitsuba=0
    [ "${1:-}" = "--mitsuba" ] && mitsuba=1
    cargo build --release --locked || exit 1
    mkdir -p .device
    objcopy --strip-all target/release/wavetrace .device/wavetrace || exit 1
    for f in "${large[@]}"; do
        if [ -f "$samples/valid/$f" ]; then
            cp "$samples/valid/$f" .device/
        else
            echo "notice: $samples/valid/$f is absent: step 4 measures the terrain alone"
        fi
    done
    if ! ls .gl/*.deb >/dev/null 2>&1; then
        # The device README's recipe: the loaders, as amd64 packages, unpacked there.
        local o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64)
        mkdir -p .gl /tmp/amd64/partial
        apt-get "${o[@]}" update -qq &&
            (cd .gl && apt-get "${o[@]}" download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2) ||
            echo "warning: the Vulkan loader packages could not be downloaded into .gl/"
    fi
    if [ $mitsuba = 1 ]; then
        local whl
        whl=$(mktemp -d)
        python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 \
            --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
            --platform manylinux_2_17_x86_64 -d "$whl" mitsuba==3.9.1 drjit==1.5.0 || exit 1
        rm -rf .device/site && mkdir -p .device/site
        for w in "$whl"/*.whl; do
            python3 -m zipfile -e "$w" .device/site || exit 1
        done
        # Unpacked the two are 190 MB, past the 64 MiB that may travel: keep the bindings of
        # two variants and the plugins tools/mitsuba_bench.py's scenes name (plus the textures
        # and spectra an RGB scene loads by default), drop headers, stubs and the spectral
        # upsampling table, and send them compressed.
        local m=.device/site/mitsuba keep=" area box d65 diffuse hdrfilm independent merge path perspective ply srgb twosided uniform "
        find $m -maxdepth 1 -name '*.cpython-*.so' ! -name 'cuda_ad_rgb.*' ! -name 'scalar_rgb.*' \
            ! -name 'mitsuba_*' -delete
        for p in $m/plugins/*.so; do
            case "$keep" in *" $(basename "$p" .so) "*) ;; *) rm "$p" ;; esac
        done
        rm -rf $m/include $m/data/srgb.coeff .device/site/drjit/include
        find .device/site -name '*.pyi' -delete
        tar -C .device -cJf .device/site.tar.xz site && rm -rf .device/site "$whl"
    fi
    echo "what travels (carry .device and .gl; the repository's own files come too):"
    du -sh .device .gl
    echo 'run(command="bash tools/device_check.sh run", carry=[".device", ".gl"], timeout_s=540)'
}

# step NAME SECONDS COMMAND...: runs it under a time limit, logging its wall time and status.
step() {
    local name=$1 limit=$2
    shift 2
    echo
    echo "== $name ($(date -u +%H:%M:%S), limit ${limit} s): $*"
    local t0=$SECONDS
    timeout --kill-after=10 "$limit" "$@"
    local rc=$?
    echo "== $name: exit $rc after $((SECONDS - t0)) s"
}

run() {
    local size=1024 spp=64
    if [ "${1:-}" = "--quick" ]; then
        size=128
        spp=4
    fi
    local out="${OUT:-$root/target/device-check}"
    mkdir -p "$out"
    exec > >(tee "$out/device_check.log") 2>&1
    echo "wavetrace device check, $(date -u), $(nproc) cores, git $(git rev-parse --short HEAD 2>/dev/null || echo '?')"
    if ! ldconfig -p | grep -q 'libvulkan.so.1 '; then
        for f in .gl/*.deb; do [ -f "$f" ] && dpkg -x "$f" /; done
        ldconfig
    fi
    local icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
    if [ -f "$icd" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
        export VK_DRIVER_FILES=$icd
    fi
    local wt=.device/wavetrace
    [ -x "$wt" ] || wt=target/release/wavetrace
    local scenes=()
    for f in "${large[@]}"; do
        [ -f ".device/$f" ] && scenes+=(".device/$f")
    done
    local terrain=/tmp/terrain-2000000.gltf
    step "terrain scene" 120 python3 tools/gen_large.py terrain "$terrain" --triangles 2000000 --texture 1024 &&
        scenes+=("$terrain")

    step "GPU" 30 nvidia-smi -L
    step "render --device auto" 120 "$wt" render scenes/cornell-box.gltf --width 256 --height 256 \
        --spp 16 --stats -o "$out/cornell-box.png"
    step "verify" 240 "$wt" verify scenes/*.gltf --width 64 --spp 256 --max-depth 7
    step "bench cornell-box" 120 "$wt" bench --gpu-only --width $size --height $size --spp $spp \
        --json "$out/bench-cornell.json" scenes/cornell-box.gltf
    step "bench large scenes" 240 "$wt" bench --gpu-only --width $size --height $size --spp $spp \
        --environment 1 --json "$out/bench-large.json" "${scenes[@]}"
    step "bench --bvh" 120 "$wt" bench --bvh --builds 5 "${scenes[@]}"
    if [ -f .device/site.tar.xz ] && tar -C /tmp -xJf .device/site.tar.xz; then
        local variant=cuda_ad_rgb
        [ "${1:-}" = "--quick" ] && variant=scalar_rgb
        step "Mitsuba $variant" 180 env PYTHONPATH=/tmp/site "${PYTHON:-python3}" tools/mitsuba_bench.py \
            scenes/cornell-box.gltf --variant $variant --width $size --height $size --spp $spp
        step "wavetrace, as Mitsuba samples" 120 "$wt" bench --gpu-only --width $size --height $size \
            --spp $spp --sampler independent --light-sampler power scenes/cornell-box.gltf
    fi
    echo
    echo "== done ($(date -u +%H:%M:%S)); files in $out"
}

case "${1:-}" in
prepare)
    shift
    prepare "$@"
    ;;
run)
    shift
    run "$@"
    ;;
*)
    sed -n '2,32p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
