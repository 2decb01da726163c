#!/usr/bin/env bash
# The real-GPU checks and figures issue 13 asks for, as one prepared run of the project's
# `device` tool (a lent machine with one NVIDIA H100 or H200, its Vulkan driver, no Rust and no
# network, and 15 minutes of device time per session, start-up included), so a session that is
# lent one spends it measuring rather than setting up.
#
#   tools/device_check.sh prepare [--mitsuba] [--tests]   here: fills .device/ and .gl/ (ignored)
#   run(command="bash tools/device_check.sh run", carry=[".device", ".gl"], timeout_s=600)
#   run(command="bash tools/device_check.sh run --tests twins integrators", ...)  those alone
#   tools/device_check.sh run --quick                     here, on lavapipe: the same steps,
#                                           small (PYTHON=python3.12 for the Mitsuba step)
#
# `prepare` builds the release binary and packs a stripped copy into .device/, with the two
# Khronos sample models the figures name read from ../shared/gltf-samples (third-party data:
# copied into the ignored .device/ for the trip, never committed) and the Vulkan loader
# packages the device README names in .gl/. --mitsuba adds Mitsuba 3 and Dr.Jit (Python 3.12
# wheels trimmed to the scalar_rgb and cuda_ad_rgb variants); --tests adds the test binaries
# that open a GPU, stripped, and the whole samples folder they read. All of it travels under
# the tool's 64 MiB (about 56 MB with both options).
#
# `run` writes under $OUT (the tool brings back at most 8 files): device_check.log (every
# step's output, its wall time and exit status), tests.log (the test binaries' whole output),
# bench-cornell.json, bench-large.json, kernels-path.json, kernels-bdpt.json
# (`wavetrace bench --json`) and cornell-box.png. A step that fails or runs past its limit is
# logged and the next one runs. The steps, figures first:
#   1. nvidia-smi, and `render --device auto` of the Cornell box, which must choose the GPU;
#   2. `bench --gpu-only` of the Cornell box (1024², 64 spp, depth 8): samples/s, rays/s and
#      per-kernel ms, with its ratio to the H200's figures of 4 December 2026
#      (tools/bench-h200.json; steps 2 and 3), and the driver's statistics of each kernel
#      (registers, local memory: what bounds the rays a multiprocessor keeps in flight);
#   3. `bench --gpu-only --environment 1` of TransmissionTest (129k triangles),
#      MetalRoughSpheresNoTextures (1M) and a 2M-triangle terrain (tools/gen_large.py): the
#      issue's ≥ 1 G rays/s, extension + shadow (the uniform environment gives the unlit
#      spheres shadow rays);
#   4. with Mitsuba packed: its cuda_ad_rgb on the Cornell box at step 2's settings
#      (tools/mitsuba_bench.py), then wavetrace sampling as Mitsuba does;
#   5. the Cornell box with a quarter, half and twice the default paths in flight; every scene
#      with its data in storage buffers and without the fetch counters; BDPT;
#   6. `bench --bvh` of the large scenes on the machine's cores and, on the GPU, `extend` and
#      `connect` alone on the same 2^20 random rays (the walks' rates without the wavefront
#      around them, and their answers against the CPU reference's), and `bench --kernels`
#      (every kernel's registers and local memory as the driver compiles it, path tracer and
#      BDPT);
#   7. `verify scenes/*.gltf` as CI runs it: the GPU against the CPU reference on every scene;
#   8. with the tests packed: each GPU test binary, as `cargo test --release` runs it here
#      (the binaries read files under the path they were built in, which `run` links to).
set -uo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root" || exit 2
samples="${WAVETRACE_SAMPLES:-$root/../shared/gltf-samples}"
large=(TransmissionTest.glb MetalRoughSpheresNoTextures.glb)
# The test binaries that open a GPU (tests/common's `gpu()`), quickest first as they ran on an
# H200 with 16 cores (4 December 2026: 1 to 8 s each up to gpu_vs_cpu, then 13 to 83 s; about
# 430 s in all).
gpu_tests=(twins surface_twins light_bvh_twins verify furnace cli adaptive shards
    light_sampling gpu_vs_cpu dispersion punctual environment materials transmission_extensions
    bidir texture_spec material_extensions real_files)

prepare() {
    local mitsuba=0 tests=0
    for a in "$@"; do
        case "$a" in
        --mitsuba) mitsuba=1 ;;
        --tests) tests=1 ;;
        *) echo "prepare: unknown option $a" >&2 && exit 2 ;;
        esac
    done
    cargo build --release --locked || exit 1
    rm -rf .device && mkdir -p .device/pack/tests
    objcopy --strip-all target/release/wavetrace .device/pack/wavetrace || exit 1
    # Where the test binaries look for the repository and its ../shared (env!("CARGO_MANIFEST_DIR")).
    echo "$root" >.device/pack/built_in
    for f in "${large[@]}"; do
        if [ -f "$samples/valid/$f" ]; then
            cp "$samples/valid/$f" .device/
        else
            echo "notice: $samples/valid/$f is absent: step 3 measures the terrain alone"
        fi
    done
    if [ $tests = 1 ]; then
        local list
        list=$(cargo test --release --locked --no-run --message-format=json 2>/dev/null |
            python3 -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and "test" in m["target"]["kind"]:
        print(m["target"]["name"], m["executable"])') || exit 1
        for t in "${gpu_tests[@]}"; do
            local exe
            exe=$(echo "$list" | awk -v t="$t" '$1 == t {print $2}')
            [ -n "$exe" ] || { echo "prepare: no test binary $t" >&2 && exit 1; }
            objcopy --strip-all "$exe" ".device/pack/tests/$t" || exit 1
        done
        if [ -d "$samples" ]; then
            cp -r --no-preserve=mode "$samples" .device/gltf-samples
        else
            echo "notice: $samples is absent: the real-file tests will skip there"
        fi
    fi
    # One archive: the binaries share most of their code, which xz finds (100 MB -> 10 MB).
    tar -C .device -cJf .device/pack.tar.xz pack && rm -rf .device/pack
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
        mkdir -p .device/site
        for w in "$whl"/*.whl; do
            python3 -m zipfile -e "$w" .device/site || exit 1
        done
        # Unpacked the two are 190 MB: keep the bindings of two variants and the plugins
        # tools/mitsuba_bench.py's scenes name (and the textures and spectra an RGB scene loads
        # by default), drop headers, stubs and the spectral upsampling table, and compress.
        local m=.device/site/mitsuba
        local keep=" area box d65 diffuse hdrfilm independent merge path perspective ply srgb twosided uniform "
        find $m -maxdepth 1 -name '*.cpython-*.so' ! -name 'cuda_ad_rgb.*' ! -name 'scalar_rgb.*' \
            ! -name 'mitsuba_*' -delete
        for p in $m/plugins/*.so; do
            case "$keep" in *" $(basename "$p" .so) "*) ;; *) rm "$p" ;; esac
        done
        rm -rf $m/include $m/data/srgb.coeff .device/site/drjit/include
        find .device/site -name '*.pyi' -delete
        tar -C .device -cJf .device/site.tar.xz site && rm -rf .device/site "$whl"
    fi
    echo "what travels (carry .device and .gl; the repository's tracked files come too):"
    du -sh .device .gl
    echo 'run(command="bash tools/device_check.sh run", carry=[".device", ".gl"], timeout_s=600)'
}

# unpack ARCHIVE: into /tmp, with tar or, where xz is missing, Python's tarfile.
unpack() {
    tar -C /tmp -xJf "$1" 2>/dev/null ||
        python3 -c 'import sys, tarfile; tarfile.open(sys.argv[1]).extractall("/tmp")' "$1"
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
    return $rc
}

# figures WAVETRACE OUT QUICK SIZE SPP: the benchmark steps (1 to 6).
figures() {
    local wt=$1 out=$2 quick=$3 size=$4 spp=$5
    local scenes=()
    for f in "${large[@]}"; do
        [ -f ".device/$f" ] && scenes+=(".device/$f")
    done
    local terrain=/tmp/terrain-2000000.gltf
    step "terrain scene" 120 python3 tools/gen_large.py terrain "$terrain" --triangles 2000000 \
        --texture 1024 && scenes+=("$terrain")

    step "GPU" 30 nvidia-smi -L
    step "render --device auto" 120 "$wt" render scenes/cornell-box.gltf --width 256 --height 256 \
        --spp 16 --stats -o "$out/cornell-box.png"
    step "bench cornell-box" 120 "$wt" bench --gpu-only --width $size --height $size --spp $spp \
        --json "$out/bench-cornell.json" --baseline tools/bench-h200.json scenes/cornell-box.gltf
    step "bench large scenes" 240 "$wt" bench --gpu-only --width $size --height $size --spp $spp \
        --environment 1 --json "$out/bench-large.json" --baseline tools/bench-h200.json \
        "${scenes[@]}"
    if [ -f .device/site.tar.xz ] && unpack .device/site.tar.xz; then
        local variant=cuda_ad_rgb
        [ $quick = 1 ] && variant=scalar_rgb
        step "Mitsuba $variant" 180 env PYTHONPATH=/tmp/site "${PYTHON:-python3}" \
            tools/mitsuba_bench.py scenes/cornell-box.gltf --variant $variant --width $size \
            --height $size --spp $spp
        step "wavetrace, as Mitsuba samples" 120 "$wt" bench --gpu-only --width $size \
            --height $size --spp $spp --sampler independent --light-sampler power \
            scenes/cornell-box.gltf
    fi
    # How many paths in flight a real GPU wants: a quarter and half the default (2^21).
    for w in 262144 1048576; do
        step "bench cornell-box --wavefront $w" 60 "$wt" bench --gpu-only --width $size \
            --height $size --spp $spp --wavefront $w scenes/cornell-box.gltf
    done
    # Twice the new default in flight (the most 65535 workgroups hold), the scene read from
    # storage buffers instead of images (chosen for llvmpipe), and without the fetch counters.
    step "bench cornell-box --wavefront 4194240" 60 "$wt" bench --gpu-only --width $size \
        --height $size --spp $spp --wavefront 4194240 scenes/cornell-box.gltf
    step "bench, scene in storage buffers" 240 env WAVETRACE_SCENE_IMAGES=buffers "$wt" bench \
        --gpu-only --width $size --height $size --spp $spp --environment 1 \
        scenes/cornell-box.gltf "${scenes[@]}"
    # A GPU reads the scene as sampled images by default; lavapipe's choice, storage images.
    step "bench, scene in storage images" 240 env WAVETRACE_SCENE_IMAGES=storage "$wt" bench \
        --gpu-only --width $size --height $size --spp $spp --environment 1 \
        scenes/cornell-box.gltf "${scenes[@]}"
    step "bench, no fetch counts" 240 "$wt" bench --gpu-only --no-fetch-counts --width $size \
        --height $size --spp $spp --environment 1 scenes/cornell-box.gltf "${scenes[@]}"
    step "bench light tracing and BDPT" 120 "$wt" bench --gpu-only --width $size --height $size \
        --spp $((spp / 4)) --integrator bdpt scenes/cornell-box.gltf scenes/caustic.gltf
    step "bench --bvh" 180 "$wt" bench --bvh --builds 5 --json "$out/bvh.json" \
        scenes/cornell-box.gltf "${scenes[@]}"
    # The driver's registers, spills and local memory of every kernel of every committed scene
    # and of the large ones, path tracer and BDPT (made, not run: seconds), against what AMD's
    # compiler says of the same kernels (tools/kernels-radv-path.json, kernels-radv-bdpt.json).
    for i in path bdpt; do
        step "bench --kernels --integrator $i" 120 "$wt" bench --kernels --integrator $i \
            --json "$out/kernels-$i.json" scenes/*.gltf "${scenes[@]}"
    done
}

run() {
    local quick=0 size=1024 spp=64 only=()
    while [ $# -gt 0 ]; do
        case "$1" in
        --quick) quick=1 size=128 spp=4 ;;
        --tests)
            shift
            only=("$@")
            break
            ;;
        *) echo "run: unknown option $1" >&2 && exit 2 ;;
        esac
        shift
    done
    local out="${OUT:-$root/target/device-check}"
    mkdir -p "$out"
    exec > >(tee "$out/device_check.log") 2>&1
    local tee_pid=$!
    echo "wavetrace device check, $(date -u), $(nproc) cores, git $(git rev-parse --short HEAD 2>/dev/null || echo '?')"
    if ! ldconfig -p | grep -q 'libvulkan.so.1 '; then
        for f in .gl/*.deb; do [ -f "$f" ] && dpkg -x "$f" /; done
        ldconfig
    fi
    local icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
    if [ -f "$icd" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
        export VK_DRIVER_FILES=$icd
    fi
    local wt=target/release/wavetrace tests=()
    if [ -f .device/pack.tar.xz ]; then
        rm -rf /tmp/pack && unpack .device/pack.tar.xz || exit 1
        wt=/tmp/pack/wavetrace
        # In gpu_tests' order: the twin tests first (quick, and the ones a new driver's
        # arithmetic tests hardest), the slowest last.
        for t in "${gpu_tests[@]}"; do
            [ -x "/tmp/pack/tests/$t" ] && tests+=("/tmp/pack/tests/$t")
        done
    fi
    if [ ${#only[@]} -gt 0 ]; then
        tests=()
        for t in "${only[@]}"; do tests+=("/tmp/pack/tests/$t"); done
    else
        figures "$wt" "$out" $quick $size $spp
    fi
    [ ${#only[@]} -gt 0 ] || step "verify" 240 "$wt" verify scenes/*.gltf --width 64 --spp 256 --max-depth 7
    if [ ${#tests[@]} -gt 0 ]; then
        # The binaries name files under the folder they were built in and its ../shared, and
        # run the CLI from its target/release: make those paths lead here.
        local built_in
        built_in=$(cat /tmp/pack/built_in)
        if [ "$built_in" != "$root" ] && [ ! -e "$built_in" ]; then
            mkdir -p "$(dirname "$built_in")" && ln -s "$root" "$built_in"
        fi
        if [ -d .device/gltf-samples ] && [ ! -e "$built_in/../shared/gltf-samples" ]; then
            mkdir -p "$built_in/../shared" && ln -s "$root/.device/gltf-samples" "$built_in/../shared/gltf-samples"
        fi
        if [ ! -x target/release/wavetrace ]; then
            mkdir -p target/release && cp "$wt" target/release/wavetrace
        fi
        [ $quick = 1 ] && [ ${#only[@]} -eq 0 ] && tests=(/tmp/pack/tests/twins /tmp/pack/tests/verify)
        # The tool's call ends at 600 s: every test binary must end by the run's
        # DEVICE_CHECK_END-th second (580); one with under 30 s left is not started but named
        # for a `run --tests` call of its own.
        local skipped=() left
        for t in "${tests[@]}"; do
            left=$((${DEVICE_CHECK_END:-580} - SECONDS))
            if [ $left -lt 30 ]; then
                skipped+=("$(basename "$t")")
                continue
            fi
            [ $left -gt 300 ] && left=300
            # Whole in tests.log (a failing twin test names every disagreement there).
            step "test $(basename "$t")" $left "$t" --test-threads "$(nproc)" 2>&1 |
                tee -a "$out/tests.log" |
                grep -E '^(==|test result|failures:|    [a-z_:]+$|thread .* panicked|GPU tests on)'
        done
        if [ ${#skipped[@]} -gt 0 ]; then
            echo
            echo "== not started, the time being spent: run --tests ${skipped[*]}"
        fi
    fi
    echo
    echo "== done ($(date -u +%H:%M:%S)); files in $out"
    # The log is whole before the tool collects $OUT.
    exec >&- 2>&-
    wait "$tee_pid" 2>/dev/null
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
    sed -n '2,40p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
