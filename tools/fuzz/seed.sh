#!/usr/bin/env bash
# Fills the fuzzer's corpus folder tools/fuzz/corpus/load_render (gitignored) with seeds: the
# project's hostile corpus (tests/hostile) and the third-party glTF samples, read from where they
# are (../shared/gltf-samples beside the repository, or $WAVETRACE_SAMPLES) and never committed.
# Seeds over MAX_LEN bytes (default 512 KiB, the -max_len of the command in docs/security.md) are left out.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
samples="${WAVETRACE_SAMPLES:-$root/../shared/gltf-samples}"
[ -d "$samples" ] || echo "seed: $samples is absent: seeding from tests/hostile only" >&2
python3 "$here/embed.py" --out "$here/corpus/load_render" --max-len "${MAX_LEN:-524288}" \
    "$root/tests/hostile" "$samples/valid" "$samples/invalid"
