#!/usr/bin/env bash
# Runs the sharded render on the current kubectl context: the volume and the shard Job, then,
# once every index completed, the merge Job. Copy the scene onto the volume first (e.g. with a
# helper pod) as render-job.yaml's SCENE.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
kubectl apply -f "$here/render-job.yaml"
kubectl wait --for=condition=complete --timeout=24h job/wavetrace-shards
kubectl apply -f "$here/merge-job.yaml"
kubectl wait --for=condition=complete --timeout=1h job/wavetrace-merge
