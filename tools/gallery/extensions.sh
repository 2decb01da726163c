#!/bin/sh
# Renders the Khronos material-extension test models docs/materials.md's "Material extensions" section
# shows, small, into tools/gallery/ext-*.png:
#
#     sh tools/gallery/extensions.sh                  # CPU reference (faster than lavapipe), builds wavetrace
#     WAVETRACE=target/release/wavetrace DEVICE=gpu sh tools/gallery/extensions.sh
#
# The models are third-party test data read from ../shared/gltf-samples/valid/extensions/ (never
# copied here; see that folder's README for sources and licences):
#   UnlitTest, SpecularTest, ClearCoatTest: Ed Mackey, Analytical Graphics, Inc. (CC BY 4.0)
#   ClearCoatCarPaint: Eric Chadwick (CC0 1.0)
#   SheenCloth: Microsoft (CC0 1.0)
#   AnisotropyStrengthTest: Ed Mackey (CC0 1.0)
#   AnisotropyRotationTest: Ed Mackey, Analytical Graphics, Inc. (CC BY 4.0)
#   IridescenceSuzanne: Mathias Kanzler, Pascal Schoen, UX3D (CC0 1.0)
#   AttenuationTest, TransmissionRoughnessTest: Ed Mackey, Analytical Graphics, Inc. (CC BY 4.0)
# They are lit by the Poly Haven map studio_small_03_1k.hdr (CC0) from ../shared/gltf-samples/env/,
# SpecularTest by a uniform white environment and UnlitTest by nothing (it is its own light);
# scenes/leaf.gltf and scenes/prism.gltf (ours, tools/gen_scenes.py) by their own lights; the
# prism with BDPT at 256 samples (its slit is seen only through the glass).
set -eu
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SAMPLES=${SAMPLES:-$ROOT/../shared/gltf-samples/valid/extensions}
ENV=${ENV:-$ROOT/../shared/gltf-samples/env/studio_small_03_1k.hdr}
DEVICE=${DEVICE:-cpu}
SPP=${SPP:-64}
OUT=$ROOT/tools/gallery
if [ -z "${WAVETRACE:-}" ]; then
    (cd "$ROOT" && cargo build --release --quiet)
    WAVETRACE=$ROOT/target/release/wavetrace
fi
render() {
    name=$1; shift
    echo "$WAVETRACE render $* --device $DEVICE -o $OUT/$name.png"
    "$WAVETRACE" render "$@" --device "$DEVICE" --spp "$SPP" --max-depth 6 -o "$OUT/$name.png"
}
render ext-unlit "$SAMPLES/UnlitTest.glb" --width 200 --height 200 --environment 0
render ext-specular "$SAMPLES/SpecularTest.glb" --width 240 --height 200 --environment 1
render ext-clearcoat "$SAMPLES/ClearCoatTest.glb" --width 240 --height 240 --env "$ENV"
render ext-clearcoat-car-paint "$SAMPLES/ClearCoatCarPaint.glb" --width 200 --height 200 --env "$ENV"
render ext-sheen-cloth "$SAMPLES/SheenCloth/SheenCloth.gltf" --width 200 --height 200 --env "$ENV"
render ext-anisotropy-strength "$SAMPLES/AnisotropyStrengthTest.glb" --width 240 --height 160 --env "$ENV"
render ext-anisotropy-rotation "$SAMPLES/AnisotropyRotationTest.glb" --width 240 --height 160 --env "$ENV"
render ext-iridescence-suzanne "$SAMPLES/IridescenceSuzanne.glb" --width 200 --height 200 --env "$ENV"
render ext-attenuation "$SAMPLES/AttenuationTest.glb" --width 240 --height 200 --environment 1
render ext-transmission-roughness "$SAMPLES/TransmissionRoughnessTest.glb" --width 320 --height 200 --env "$ENV"
render ext-leaf "$ROOT/scenes/leaf.gltf" --width 200 --height 200 --environment 0
echo "$WAVETRACE render $ROOT/scenes/prism.gltf --integrator bdpt --device $DEVICE -o $OUT/ext-prism.png"
"$WAVETRACE" render "$ROOT/scenes/prism.gltf" --integrator bdpt --device "$DEVICE" --spp 256 --max-depth 6 \
    --width 240 --height 160 -o "$OUT/ext-prism.png"
