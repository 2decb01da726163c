#!/bin/sh
# Renders docs/usage.md's pictures of the output options (issue 59) into tools/gallery/:
#
#     sh tools/gallery/outputs.sh                     # GPU (lavapipe or a real one), builds wavetrace
#     WAVETRACE=target/release/wavetrace DEVICE=cpu sh tools/gallery/outputs.sh
#
# - views-*.png: DamagedHelmet (theblueturtle_, CC BY 4.0) under venice_sunset_1k.hdr
#   (Poly Haven, CC0) at +1 stop, through each view transform;
# - denoise-*.png: the Cornell box at 4 spp, noisy and denoised (`--denoise`, which needs
#   `bash tools/install_oidn.sh`), and the 1024-spp render they approach.
# The models and maps are read from ../shared/gltf-samples/ (never copied here).
set -eu
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SAMPLES=${SAMPLES:-$ROOT/../shared/gltf-samples}
DEVICE=${DEVICE:-gpu}
OUT=$ROOT/tools/gallery
if [ -z "${WAVETRACE:-}" ]; then
    (cd "$ROOT" && cargo build --release --quiet)
    WAVETRACE=$ROOT/target/release/wavetrace
fi
render() {
    name=$1; shift
    echo "$WAVETRACE render $* --device $DEVICE -o $OUT/$name.png"
    "$WAVETRACE" render "$@" --device "$DEVICE" --quiet -o "$OUT/$name.png"
}
for view in standard khronos-pbr-neutral agx filmic; do
    render "views-$view" "$SAMPLES/valid/DamagedHelmet.glb" --env "$SAMPLES/env/venice_sunset_1k.hdr" \
        --width 256 --height 256 --spp 64 --exposure 1 --view "$view"
done
render views-agx-punchy "$SAMPLES/valid/DamagedHelmet.glb" --env "$SAMPLES/env/venice_sunset_1k.hdr" \
    --width 256 --height 256 --spp 64 --exposure 1 --view agx --look punchy
render denoise-cornell-box "$ROOT/scenes/cornell-box.gltf" --width 256 --spp 4 --denoise
render denoise-cornell-box-reference "$ROOT/scenes/cornell-box.gltf" --width 256 --spp 1024
