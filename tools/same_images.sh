#!/usr/bin/env bash
# Renders a fixed set of images with one wavetrace binary, so that a change meant to leave every
# image as it was (a refactoring) can be proved bit for bit: run it with the binary built before
# the change and with the one after, then compare the two folders.
#
#   tools/same_images.sh render BINARY OUT_DIR   # every committed scene on the CPU reference and
#                                                # the GPU (path tracing), light tracing and BDPT,
#                                                # path layers, AOVs, a progressive render, and
#                                                # DamagedHelmet under an HDR map (when
#                                                # ../shared/gltf-samples is there)
#   tools/same_images.sh compare DIR_A DIR_B     # exit 0 when every file is byte-identical
#
# The EXRs are compared byte for byte (the same render writes the same bytes, image_io.rs).
set -euo pipefail
cd "$(dirname "$0")/.."

render_all() {
    local bin=$1 out=$2
    mkdir -p "$out"
    local small=(--width 48 --height 48 --spp 8 --seed 7)
    for scene in scenes/*.gltf; do
        local name
        name=$(basename "$scene" .gltf)
        for device in cpu gpu; do
            "$bin" render "$scene" "${small[@]}" --device "$device" -o "$out/$name-path-$device.exr"
        done
    done
    for scene in scenes/cornell-box.gltf scenes/veach-mis.gltf scenes/caustic.gltf; do
        local name
        name=$(basename "$scene" .gltf)
        for integrator in light bdpt; do
            for device in cpu gpu; do
                "$bin" render "$scene" "${small[@]}" --device "$device" --integrator "$integrator" \
                    -o "$out/$name-$integrator-$device.exr"
            done
        done
    done
    for device in cpu gpu; do
        "$bin" render scenes/caustic.gltf "${small[@]}" --device "$device" \
            --aov caustics=LS+DE --aov direct=L.E -o "$out/caustic-layers-$device.exr"
        "$bin" render scenes/cornell-materials.gltf "${small[@]}" --device "$device" \
            --aov normal -o "$out/materials-normal-$device.exr"
        "$bin" render scenes/cornell-box.gltf --width 32 --height 32 --spp 4 --seed 3 \
            --device "$device" --target-error 0.2 --max-spp 64 -o "$out/cornell-passes-$device.exr"
    done
    local samples=../shared/gltf-samples
    if [ -f "$samples/valid/DamagedHelmet.glb" ]; then
        for device in cpu gpu; do
            "$bin" render "$samples/valid/DamagedHelmet.glb" --width 64 --height 64 --spp 8 \
                --env "$samples/env/studio_small_03_1k.hdr" --device "$device" \
                -o "$out/damaged-helmet-env-$device.exr"
        done
    else
        echo "notice: $samples is absent: DamagedHelmet under an HDR map is left out"
    fi
}

case "${1:-}" in
    render) render_all "$2" "$3" ;;
    compare)
        status=0
        for a in "$2"/*.exr; do
            b="$3/$(basename "$a")"
            if [ ! -f "$b" ]; then echo "missing: $b"; status=1
            elif cmp -s "$a" "$b"; then echo "same: $(basename "$a")"
            else echo "DIFFERENT: $(basename "$a")"; status=1; fi
        done
        exit $status ;;
    *) sed -n '2,13p' "$0"; exit 2 ;;
esac
