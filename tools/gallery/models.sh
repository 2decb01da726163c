#!/bin/sh
# Renders the Khronos sample models the README shows, textured, into tools/gallery/:
#
#     sh tools/gallery/models.sh                      # GPU (lavapipe or a real one), builds wavetrace
#     WAVETRACE=target/release/wavetrace DEVICE=cpu sh tools/gallery/models.sh
#
# The models are third-party data read from ../shared/gltf-samples/valid/ (never copied here);
# each image is credited in the README. Lit by a uniform white environment (--environment),
# until environment maps arrive.
set -eu
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SAMPLES=${SAMPLES:-$ROOT/../shared/gltf-samples/valid}
DEVICE=${DEVICE:-gpu}
OUT=$ROOT/tools/gallery
if [ -z "${WAVETRACE:-}" ]; then
    (cd "$ROOT" && cargo build --release --quiet)
    WAVETRACE=$ROOT/target/release/wavetrace
fi
render() {
    name=$1; shift
    echo "$WAVETRACE render $* --device $DEVICE -o $OUT/$name.png"
    "$WAVETRACE" render "$@" --device "$DEVICE" -o "$OUT/$name.png"
}
render damaged-helmet "$SAMPLES/DamagedHelmet.glb" --width 360 --height 360 --spp 256 \
    --environment 0.8 --max-depth 6
render cesium-milk-truck "$SAMPLES/CesiumMilkTruck.glb" --width 360 --height 360 --spp 256 \
    --environment 0.8 --max-depth 6
render transmission-test "$SAMPLES/TransmissionTest.glb" --width 480 --spp 128 \
    --environment 1 --max-depth 10
