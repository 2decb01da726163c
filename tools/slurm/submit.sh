#!/usr/bin/env bash
# Submits a sharded wavetrace render to Slurm: an array of SHARDS tasks (shard.sbatch), one GPU
# each, and a merge job (merge.sbatch) that starts when all of them succeeded. Prints
# "ARRAY_JOB_ID MERGE_JOB_ID".
#
#   SCENE=/shared/scene.gltf SPP=4096 SHARDS=16 OUT_DIR=/shared/out \
#       RENDER_OPTIONS="--width 1920 --height 1080" tools/slurm/submit.sh
#
# With FRAMES=A..B set, submits the frames of an animation instead: an array of TASKS tasks
# (frames.sbatch; TASKS defaults to SHARDS, then 1), each rendering its share of the frames
# whole, and no merge. Prints "ARRAY_JOB_ID".
#
#   SCENE=/shared/walk.glb FRAMES=1..240 FPS=24 TASKS=16 SPP=256 OUT_DIR=/shared/frames \
#       tools/slurm/submit.sh   # → /shared/frames/frame_0001.png … frame_0240.png
#
# WAVETRACE_GRES: the generic resource each shard asks for (default gpu:1); set it empty
# (WAVETRACE_GRES=) on CPU-only clusters, with DEVICE=cpu. SBATCH_OPTIONS: more sbatch options
# for both jobs (e.g. "--partition=gpu --time=2:00:00"), split on spaces. The other variables
# are those of shard.sbatch; sbatch passes the environment on to the jobs.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
gres=${WAVETRACE_GRES-gpu:1}
if [ -n "${FRAMES:-}" ]; then
    : "${SCENE:?set SCENE}" "${OUT_DIR:?set OUT_DIR}"
    TASKS=${TASKS:-${SHARDS:-1}}
    export SCENE FRAMES TASKS OUT_DIR
    mkdir -p "$OUT_DIR"
    # shellcheck disable=SC2086 # SBATCH_OPTIONS is a list of options
    array=$(sbatch --parsable --export=ALL --array="0-$((TASKS - 1))" ${gres:+--gres="$gres"} \
        --output="$OUT_DIR/frames-%a.log" ${SBATCH_OPTIONS:-} "$here/frames.sbatch")
    echo "${array%%;*}"
    exit 0
fi
: "${SCENE:?set SCENE}" "${SPP:?set SPP}" "${SHARDS:?set SHARDS}" "${OUT_DIR:?set OUT_DIR}"
export SCENE SPP SHARDS OUT_DIR
mkdir -p "$OUT_DIR"
# shellcheck disable=SC2086 # SBATCH_OPTIONS is a list of options
array=$(sbatch --parsable --export=ALL --array="0-$((SHARDS - 1))" ${gres:+--gres="$gres"} \
    --output="$OUT_DIR/shard-%a.log" ${SBATCH_OPTIONS:-} "$here/shard.sbatch")
array=${array%%;*}
# shellcheck disable=SC2086
merge=$(sbatch --parsable --export=ALL --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    --output="$OUT_DIR/merge.log" ${SBATCH_OPTIONS:-} "$here/merge.sbatch")
merge=${merge%%;*}
echo "$array $merge"
