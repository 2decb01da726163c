#!/usr/bin/env bash
# Renders the screenshot in docs/verification.md of a `wavetrace verify` report: every committed scene, GPU
# (lavapipe or whatever device is first) against the CPU reference, the HTML report opened in
# headless Chromium (Debian's `chromium` package).
#
#     tools/gallery/verify-report.sh        # writes tools/gallery/verify-report.png
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --quiet
out=target/gallery/verify
rm -rf "$out"
target/release/wavetrace verify scenes/*.gltf --width 64 --spp 256 --max-depth 7 --report "$out"
chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --window-size=1000,1750 \
    --screenshot="$PWD/tools/gallery/verify-report.png" "file://$PWD/$out/index.html"
