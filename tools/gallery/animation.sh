#!/bin/sh
# Renders the animation pictures of docs/usage.md ("Time, frames and poses") into tools/gallery/:
#
#     sh tools/gallery/animation.sh                    # GPU (lavapipe or a real one), builds wavetrace
#     WAVETRACE=target/release/wavetrace DEVICE=cpu sh tools/gallery/animation.sh
#
# - animation-rigged-figure-strip.png: RiggedFigure (Khronos sample, CC BY 4.0) at five moments
#   of its animation, 0 to 1.25 s, as a sequence (`--frames 0..4 --fps 3.2`), set side by side
#   (python3 with Pillow);
# - animation-interpolation-test-first.png, -last.png: the first and last frames of a 21-frame
#   sequence of InterpolationTest (frames 0 to 20 at 24 fps: the first 0.83 s of its 1.71) (Khronos sample, CC BY 4.0), every animation playing: the
#   nine cubes step, slide and spline-interpolate their scale, rotation and translation.
# The models are read from ../shared/gltf-samples/ (never copied here).
set -eu
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SAMPLES=${SAMPLES:-$ROOT/../shared/gltf-samples/valid}/animation
DEVICE=${DEVICE:-gpu}
OUT=$ROOT/tools/gallery
if [ -z "${WAVETRACE:-}" ]; then
    (cd "$ROOT" && cargo build --release --quiet)
    WAVETRACE=$ROOT/target/release/wavetrace
fi
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
"$WAVETRACE" render "$SAMPLES/RiggedFigure.glb" --device "$DEVICE" --width 160 --height 240 \
    --spp 128 --orbit 30,10 --frames 0..4 --fps 3.2 -o "$TMP/figure_#.png"
python3 - "$TMP" "$OUT/animation-rigged-figure-strip.png" <<'PY'
import sys
from PIL import Image
tmp, out = sys.argv[1], sys.argv[2]
frames = [Image.open(f"{tmp}/figure_{k}.png") for k in range(5)]
strip = Image.new("RGB", (sum(f.width for f in frames), frames[0].height))
x = 0
for f in frames:
    strip.paste(f, (x, 0))
    x += f.width
strip.save(out)
PY
"$WAVETRACE" render "$SAMPLES/InterpolationTest.glb" --device "$DEVICE" --width 360 --height 240 \
    --spp 64 --frames 0..20 --fps 24 -o "$TMP/interpolation_##.png"
cp "$TMP/interpolation_00.png" "$OUT/animation-interpolation-test-first.png"
cp "$TMP/interpolation_20.png" "$OUT/animation-interpolation-test-last.png"
