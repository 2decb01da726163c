#!/bin/sh
# Renders the two scale scenes of docs/distributed.md's "Scenes larger than one GPU binding" section into
# tools/gallery/scale-*.png, after writing them with tools/gen_large.py into a temporary folder
# (they are large and generated, so they are not kept):
#
#     sh tools/gallery/scale.sh                  # CPU reference, builds wavetrace
#     WAVETRACE=target/release/wavetrace DEVICE=gpu sh tools/gallery/scale.sh
#
# The helmets are the Khronos sample model DamagedHelmet (theblueturtle_, CC BY 4.0), read from
# ../shared/gltf-samples/valid/ (never copied here), lit by Poly Haven's venice_sunset_1k.hdr
# (CC0) from ../shared/gltf-samples/env/.
set -eu
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SAMPLES=${SAMPLES:-$ROOT/../shared/gltf-samples}
DEVICE=${DEVICE:-cpu}
SPP=${SPP:-64}
OUT=$ROOT/tools/gallery
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
if [ -z "${WAVETRACE:-}" ]; then
    (cd "$ROOT" && cargo build --release --quiet)
    WAVETRACE=$ROOT/target/release/wavetrace
fi
python3 "$ROOT/tools/gen_large.py" terrain "$TMP/terrain.glb"
python3 "$ROOT/tools/gen_large.py" helmets "$TMP/helmets.glb" --helmet "$SAMPLES/valid/DamagedHelmet.glb"
"$WAVETRACE" render "$TMP/terrain.glb" --device "$DEVICE" --width 360 --height 240 --spp "$SPP" \
    --environment 0.25,0.3,0.4 --max-depth 4 -o "$OUT/scale-terrain.png"
"$WAVETRACE" render "$TMP/helmets.glb" --device "$DEVICE" --width 360 --height 240 --spp "$SPP" \
    --env "$SAMPLES/env/venice_sunset_1k.hdr" --max-depth 4 -o "$OUT/scale-helmets.png"
