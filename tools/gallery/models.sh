#!/bin/sh
# Renders the Khronos sample models docs/materials.md shows, textured, into tools/gallery/:
#
#     sh tools/gallery/models.sh                      # GPU (lavapipe or a real one), builds wavetrace
#     WAVETRACE=target/release/wavetrace DEVICE=cpu sh tools/gallery/models.sh
#
# The models and environment maps are third-party data read from ../shared/gltf-samples/
# (never copied here); each image is credited in docs/materials.md. DamagedHelmet and CesiumMilkTruck
# are lit by Poly Haven HDR maps (--env), LightsPunctualLamp by its own KHR_lights_punctual
# lamp and a dim studio map, TransmissionTest by a uniform white environment.
set -eu
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SAMPLES=${SAMPLES:-$ROOT/../shared/gltf-samples/valid}
ENV=${ENV:-$ROOT/../shared/gltf-samples/env}
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
    --env "$ENV/venice_sunset_1k.hdr" --env-rotate 200 --max-depth 6
render cesium-milk-truck "$SAMPLES/CesiumMilkTruck.glb" --width 360 --height 360 --spp 256 \
    --env "$ENV/studio_small_03_1k.hdr" --env-rotate 180 --max-depth 6
render lights-punctual-lamp "$SAMPLES/LightsPunctualLamp/LightsPunctualLamp.gltf" --width 360 \
    --height 360 --spp 256 --env "$ENV/studio_small_03_1k.hdr" --env-scale 0.05 --max-depth 6
render transmission-test "$SAMPLES/TransmissionTest.glb" --width 480 --spp 128 \
    --environment 1 --max-depth 10
