#!/usr/bin/env bash
# How much Open Image Denoise helps: the relative MSE against a high-spp reference of the noisy
# and the denoised image at 4, 16 and 64 spp, on the Cornell box, cornell-materials and
# DamagedHelmet (under the built-in studio), and the denoiser's time. Renders on the CPU
# reference; the reference uses another seed, so its noise is independent of the images'.
#
#   bash tools/denoise_measure.sh [OUT_DIR]     (needs `bash tools/install_oidn.sh` first)
#
# Prints one line per scene and spp; the figures of a run go in docs/perf-log/.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/denoise-measure}
mkdir -p "$out"
bin=target/release/wavetrace
[ -x "$bin" ] || cargo build --release
size=${SIZE:-128}
ref_spp=${REF_SPP:-4096}
helmet=../shared/gltf-samples/valid/DamagedHelmet.glb
scenes=(scenes/cornell-box.gltf scenes/cornell-materials.gltf)
[ -f "$helmet" ] && scenes+=("$helmet") || echo "note: $helmet absent; DamagedHelmet left out" >&2
relmse() { { "$bin" compare "$1" "$2" || true; } | sed -n 's/.*relative MSE = \([0-9.eE+-]*\) .*/\1/p' | head -1; }
printf '%-22s %5s %12s %12s %7s %10s\n' scene spp noisy denoised factor denoise_s
for scene in "${scenes[@]}"; do
    name=$(basename "${scene%.*}")
    ref="$out/$name-ref.exr"
    [ -f "$ref" ] || "$bin" render "$scene" --device cpu --width "$size" --height "$size" \
        --spp "$ref_spp" --seed 1000 --quiet -o "$ref" > /dev/null
    for spp in 4 16 64; do
        noisy="$out/$name-$spp.exr" denoised="$out/$name-$spp-denoised.exr"
        "$bin" render "$scene" --device cpu --width "$size" --height "$size" --spp "$spp" \
            --quiet -o "$noisy" > /dev/null
        seconds=$("$bin" render "$scene" --device cpu --width "$size" --height "$size" \
            --spp "$spp" --quiet --denoise -o "$denoised" |
            sed -n 's/.*denoised with .* in \([0-9.]*\) s.*/\1/p')
        a=$(relmse "$noisy" "$ref") b=$(relmse "$denoised" "$ref")
        printf '%-22s %5d %12s %12s %7.1f %10s\n' "$name" "$spp" "$a" "$b" \
            "$(python3 -c "print($a / $b)")" "$seconds"
    done
done
