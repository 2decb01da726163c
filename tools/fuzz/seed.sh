#!/usr/bin/env bash
# Fills the fuzzer's corpus folder tools/fuzz/corpus/load_render (gitignored) with seeds: the
# project's hostile corpus (tests/hostile) and the third-party glTF samples, read from where they
# are (../shared/gltf-samples beside the repository, or $WAVETRACE_SAMPLES) and never committed.
# Seeds that reach the compressed-file decoders (meshopt, WebP, KTX2) are written by a test of
# tests/scene/compressed.rs; the Draco and quantized ones are among the samples.
# Seeds over MAX_LEN bytes (default 512 KiB, the -max_len of the command in docs/security.md) are left out.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
samples="${WAVETRACE_SAMPLES:-$root/../shared/gltf-samples}"
[ -d "$samples" ] || echo "seed: $samples is absent: seeding from tests/hostile only" >&2
compressed="$(mktemp -d)"
trap 'rm -rf "$compressed"' EXIT
(cd "$root" && WAVETRACE_FUZZ_SEEDS="$compressed" cargo test --release --test scene \
    write_fuzz_seeds -- --ignored --quiet)
python3 "$here/embed.py" --out "$here/corpus/load_render" --max-len "${MAX_LEN:-524288}" \
    "$root/tests/hostile" "$samples/valid" "$samples/invalid" "$compressed"
