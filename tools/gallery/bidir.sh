#!/bin/sh
# Renders the pictures of the bidirectional integrators in docs/integrators.md into tools/gallery/:
#
#     sh tools/gallery/bidir.sh        # builds wavetrace; CPU renders (the strategy images are the CPU twin's)
#
# - bdpt-strategies.png: every (s, t) strategy of the Cornell box up to three scattering
#   vertices, weighted (upper row of each pair) and unweighted (lower row): the lecture's
#   "Bidir PT example" figure, from `--bdpt-strategies`.
# - caustic-bdpt.png, caustic-only.png: the caustic scene by BDPT, and only its caustics seen on
#   a diffuse surface (`--paths 'LS+DE'`).
set -eu
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=$ROOT/tools/gallery
if [ -z "${WAVETRACE:-}" ]; then
    (cd "$ROOT" && cargo build --release --quiet)
    WAVETRACE=$ROOT/target/release/wavetrace
fi
TMP=$(mktemp -d)
"$WAVETRACE" render "$ROOT/scenes/cornell-box.gltf" --device cpu --integrator bdpt --width 128 \
    --spp 256 --max-depth 3 --bdpt-strategies "$TMP/strategies" --exposure 1 -o "$TMP/cornell.png"
cp "$TMP/strategies/strategies.png" "$OUT/bdpt-strategies.png"
"$WAVETRACE" render "$ROOT/scenes/caustic.gltf" --device cpu --integrator bdpt --width 320 \
    --spp 256 --max-depth 8 -o "$OUT/caustic-bdpt.png"
"$WAVETRACE" render "$ROOT/scenes/caustic.gltf" --device cpu --integrator bdpt --width 320 \
    --spp 256 --max-depth 8 --paths 'LS+DE' -o "$OUT/caustic-only.png"
rm -rf "$TMP"
