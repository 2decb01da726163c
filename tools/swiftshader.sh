#!/usr/bin/env bash
# Fetches SwiftShader's Vulkan driver (Google's CPU implementation of Vulkan 1.3, Apache-2.0)
# into DIR (default target/swiftshader) and prints the path of its ICD manifest, for
#   VK_ICD_FILENAMES=$(tools/swiftshader.sh) WAVETRACE_TWINS_DEVICE=SwiftShader \
#       cargo test --release --test twins
# A second Vulkan implementation whose arithmetic is its own (its sin, cos, exp and log are
# approximations within what Vulkan allows; lavapipe's agree with Rust's to an ulp or two), so
# the GLSL-twin tests show whether their tolerances hold for what the Vulkan spec allows rather
# than for lavapipe. It cannot run the renderer (it binds at most 30 storage buffers per
# kernel; the wavefront kernels bind 42), only the test kernels.
#
# SwiftShader is not packaged by Debian or Ubuntu; the npm package @sparticuz/chromium (a
# Chromium build for serverless machines, MIT) carries Chromium's build of it as
# bin/swiftshader.tar.br. The package version and its SHA-256 are pinned here. Needs curl,
# sha256sum, tar and brotli (installed with apt-get where missing). Idempotent.
set -euo pipefail

dir=${1:-target/swiftshader}
version=147.0.0
sha256=18fe5404ce845594cd7d592fc07f37a19514079ba4d9c27192ad8b908743f16b
url=https://registry.npmjs.org/@sparticuz/chromium/-/chromium-$version.tgz

if [ ! -f "$dir/vk_swiftshader_icd.json" ] || [ ! -f "$dir/libvk_swiftshader.so" ]; then
    if ! command -v brotli >/dev/null; then
        sudo=""; [ "$(id -u)" -eq 0 ] || sudo=sudo
        { $sudo apt-get update -qq && $sudo env DEBIAN_FRONTEND=noninteractive \
            apt-get install -y -qq brotli; } >&2
    fi
    mkdir -p "$dir"
    tgz="$dir/chromium-$version.tgz"
    curl -fsSL --retry 3 "$url" -o "$tgz"
    echo "$sha256  $tgz" | sha256sum -c --quiet - >&2
    tar --no-same-owner -xzf "$tgz" -C "$dir" package/bin/swiftshader.tar.br
    brotli -d -c "$dir/package/bin/swiftshader.tar.br" |
        tar --no-same-owner -x -C "$dir" libvk_swiftshader.so vk_swiftshader_icd.json
    rm -rf "$tgz" "$dir/package"
fi
echo "$(cd "$dir" && pwd)/vk_swiftshader_icd.json"
