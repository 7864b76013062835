#!/usr/bin/env bash
# Table 3 of a dataset on a Slurm job array, then one merge.
#
# usage (on a login node):
#   deploy/slurm/eval-array.sh DATASET OUT [SHARDS] [-- EVAL-OPTIONS...]
#
# Submits this script as an array of SHARDS tasks (default 4), each running
# `mapvlm eval --shard auto` over its share of DATASET into OUT/shard-I, and a
# merge job that starts when every array task has succeeded and writes the
# whole run's files and tables into OUT/merged (`mapvlm merge`). A task that
# failed is retried by submitting the same command again: eval resumes and
# asks no model twice.
#
# OUT must be on a file system every node sees. The embedding and response
# caches go there too (OUT/cache, or $MAPVLM_SHARED_CACHE), so no sentence is
# embedded and no answer paid for twice across the nodes; the model pack is
# fetched once into that cache unless $MAPVLM_MODELS points at one.
# $MAPVLM is the binary (default: mapvlm on the PATH). Provider keys come
# from the environment of the submitting shell (sbatch exports it).
#SBATCH --job-name=mapvlm-eval
#SBATCH --cpus-per-task=2
#SBATCH --mem=4G
#SBATCH --time=04:00:00
#SBATCH --output=mapvlm-eval-%A_%a.out
set -euo pipefail

mapvlm=${MAPVLM:-mapvlm}
dataset=${1:?usage: eval-array.sh DATASET OUT [SHARDS] [-- EVAL-OPTIONS...]}
out=${2:?usage: eval-array.sh DATASET OUT [SHARDS] [-- EVAL-OPTIONS...]}
shift 2
shards=4
if [ $# -gt 0 ] && [ "$1" != "--" ]; then
    shards=$1
    shift
fi
if [ $# -gt 0 ] && [ "$1" = "--" ]; then
    shift
fi
export XDG_CACHE_HOME=${MAPVLM_SHARED_CACHE:-$out/cache}

if [ -n "${SLURM_ARRAY_TASK_ID:-}" ]; then
    # One array task: its shard, I = task id - first task id + 1.
    shard=$((SLURM_ARRAY_TASK_ID - ${SLURM_ARRAY_TASK_MIN:?} + 1))
    exec "$mapvlm" eval --dataset "$dataset" --out "$out/shard-$shard" --shard auto "$@"
fi

if [ "${MAPVLM_STAGE:-}" = merge ]; then
    dirs=()
    for i in $(seq 1 "$shards"); do
        dirs+=("$out/shard-$i")
    done
    exec "$mapvlm" merge "${dirs[@]}" --out "$out/merged"
fi

mkdir -p "$out"
array=$(sbatch --parsable --array="0-$((shards - 1))" "$0" "$dataset" "$out" "$shards" -- "$@")
sbatch --dependency="afterok:${array%%;*}" --job-name=mapvlm-merge \
    --export="ALL,MAPVLM_STAGE=merge" "$0" "$dataset" "$out" "$shards"
echo "submitted array job $array ($shards shards) and its merge into $out/merged"
