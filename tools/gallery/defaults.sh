#!/bin/sh
# Renders what a new user sees with no flag at all, into tools/gallery/:
#
#     sh tools/gallery/defaults.sh                    # GPU (lavapipe or a real one), builds wavetrace
#     WAVETRACE=target/release/wavetrace DEVICE=cpu sh tools/gallery/defaults.sh
#
# DamagedHelmet (theblueturtle_, CC BY 4.0) has no lights of its own: `wavetrace render` lights
# it with the built-in studio environment (src/lights/studio.rs). TransmissionTest (Adobe, CC0)
# likewise, and its panes are thin-walled, as the glTF specification makes a transmissive
# material without KHR_materials_volume. The models are read from ../shared/gltf-samples/ (never
# copied here); docs/materials.md credits them.
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
# Without a flag but the size (and the samples, for a clean picture).
render default-damaged-helmet "$SAMPLES/DamagedHelmet.glb" --width 360 --height 360 --spp 128
render default-transmission-test "$SAMPLES/TransmissionTest.glb" --width 480 --spp 128
# The same helmet turned by hand: --orbit 40,20.
render default-damaged-helmet-orbit "$SAMPLES/DamagedHelmet.glb" --width 360 --height 360 \
    --spp 128 --orbit 40,20
# The "before" pictures docs/materials.md sets beside these (before-damaged-helmet.png,
# before-transmission-test.png) were rendered once by the build before issue 57 (a902ac5), the
# helmet with no flag and TransmissionTest as models.sh renders it:
#     git worktree add /tmp/old a902ac5 && (cd /tmp/old && cargo build --release)
#     /tmp/old/target/release/wavetrace render DamagedHelmet.glb --width 360 --height 360 --spp 128 -o before-damaged-helmet.png
#     /tmp/old/target/release/wavetrace render TransmissionTest.glb --width 480 --spp 128 --environment 1 --max-depth 10 -o before-transmission-test.png
# Compressed files (issue 57, item 5), refused before: StainedGlassLamp (Wayfair, CC BY 4.0) with
# its 17 KTX2 / Basis Universal textures, under the studio (its own light is only its bulbs).
render compressed-stained-glass-lamp "$SAMPLES/compressed/StainedGlassLamp-ktx2/StainedGlassLamp.gltf" \
    --width 360 --height 360 --spp 128 --env studio
# --sky: the daylight sky and sun (src/lights/sky.rs), by default and low in a hazy evening.
render sky-damaged-helmet "$SAMPLES/DamagedHelmet.glb" --width 360 --height 360 --spp 128 --sky
render sky-damaged-helmet-evening "$SAMPLES/DamagedHelmet.glb" --width 360 --height 360 --spp 128 \
    --sky --sun-elevation 8 --turbidity 6
