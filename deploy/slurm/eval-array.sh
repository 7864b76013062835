#!/usr/bin/env bash
# Table 3 of a dataset on a Slurm job array, then one merge.
#
# usage (on a login node):
#   deploy/slurm/eval-array.sh [SBATCH-OPTION...] DATASET OUT SHARDS [-- EVAL-OPTION...]
#
#   e.g. deploy/slurm/eval-array.sh --partition=short --time=01:00:00 --throttle=2 \
#          data/alfred30 /shared/runs/alfred30 3 -- --from-dataset-plans
#
# Submits this script as the array --array=1-SHARDS: array task K runs
# `mapvlm eval --shard K/SHARDS` over its share of DATASET into OUT/shard-K,
# and a merge job that starts when every array task has ended (afterany),
# reports the shards that failed (and then writes no table), and otherwise
# writes the whole run's files and tables into OUT/merged (`mapvlm merge`).
#
# SBATCH-OPTIONs (before DATASET, each as --name=value) go to sbatch for the
# array and the merge: --partition, --account, --qos, --time, --cpus-per-task,
# --mem, --gres (a GPU later), and so on; they override the defaults below
# (2 CPUs, 4 GB, 4 hours). --throttle=K runs at most K array tasks at once
# (--array=1-SHARDS%K) and is not given to the merge.
#
# Logs: OUT/logs/shard-K-JOBID.out for array task K (a requeued attempt is
# appended, not overwritten) and OUT/logs/merge-JOBID.out; eval writes a
# progress line (done/total, failures, rate) every 10 plans or 30 seconds.
# OUT/logs/shard-K.rc holds array task K's exit status once it has ended.
#
# Rerun one shard K (the other shards' files are not touched), then the merge:
#   sbatch --array=K --output=OUT/logs/shard-%a-%A.out --open-mode=append \
#       deploy/slurm/eval-array.sh DATASET OUT SHARDS -- EVAL-OPTION...
#   sbatch --export=ALL,MAPVLM_STAGE=merge --output=OUT/logs/merge-%j.out \
#       deploy/slurm/eval-array.sh DATASET OUT SHARDS
# (or MAPVLM_STAGE=merge deploy/slurm/eval-array.sh DATASET OUT SHARDS on the
# login node). eval resumes: no answer already made is asked for again.
#
# OUT must be on a file system every node sees. The caches are the user's
# ($XDG_CACHE_HOME, else ~/.cache): put them on a shared file system, or set
# $MAPVLM_SHARED_CACHE to a shared folder, so that no sentence is embedded
# and no answer paid for twice across nodes and runs. The model pack is
# $MAPVLM_MODELS, else the cache's mapvlm/models (fetched once, locked while
# it is fetched). $MAPVLM is the binary (default: mapvlm on the PATH).
# Provider keys come from the environment of the submitting shell (sbatch
# exports it).
#SBATCH --job-name=mapvlm-eval
#SBATCH --cpus-per-task=2
#SBATCH --mem=4G
#SBATCH --time=04:00:00
set -euo pipefail

usage() {
    echo "usage: eval-array.sh [SBATCH-OPTION...] DATASET OUT SHARDS [-- EVAL-OPTION...]" >&2
    echo "  e.g. eval-array.sh --partition=short data/alfred30 /shared/out 3 -- --from-dataset-plans" >&2
    exit 2
}

mapvlm=${MAPVLM:-mapvlm}
# This script's own path (inside a job, $0 is Slurm's copy of it).
script=${MAPVLM_SCRIPT:-$(cd "$(dirname "$0")" && pwd)/$(basename "$0")}
export MAPVLM_SCRIPT=$script
sbatch_options=()
throttle=
while [ $# -gt 0 ] && [ "${1#--}" != "$1" ] && [ "$1" != "--" ]; do
    case $1 in
        --throttle=*) throttle=${1#--throttle=} ;;
        --help) usage ;;
        *=*) sbatch_options+=("$1") ;;
        *)
            echo "eval-array.sh: $1: give sbatch options as --name=value, before DATASET" >&2
            usage
            ;;
    esac
    shift
done
[ $# -ge 3 ] || usage
dataset=$1
out=$2
shards=$3
shift 3
case $shards in
    '' | *[!0-9]* | 0) echo "eval-array.sh: SHARDS must be a whole number of at least 1, not '$shards'" >&2; usage ;;
esac
if [ $# -gt 0 ]; then
    [ "$1" = "--" ] || { echo "eval-array.sh: $1: eval options follow --" >&2; usage; }
    shift
fi
if [ -n "${MAPVLM_SHARED_CACHE:-}" ]; then
    export XDG_CACHE_HOME=$MAPVLM_SHARED_CACHE
fi
logs=$out/logs

if [ -n "${SLURM_ARRAY_TASK_ID:-}" ] && [ "${MAPVLM_STAGE:-}" != merge ]; then
    # One array task: shard K of SHARDS, K the array task id (1..SHARDS).
    k=$SLURM_ARRAY_TASK_ID
    if [ "$k" -lt 1 ] || [ "$k" -gt "$shards" ]; then
        echo "eval-array.sh: array task $k is not a shard of 1..$shards; submit --array=1-$shards (or --array=K to rerun shard K)" >&2
        exit 2
    fi
    mkdir -p "$logs"
    rm -f "$logs/shard-$k.rc"
    rc=0
    "$mapvlm" eval --dataset "$dataset" --out "$out/shard-$k" --shard "$k/$shards" "$@" || rc=$?
    echo "$rc" >"$logs/shard-$k.rc"
    exit "$rc"
fi

if [ "${MAPVLM_STAGE:-}" = merge ]; then
    dirs=()
    failed=()
    for k in $(seq 1 "$shards"); do
        dirs+=("$out/shard-$k")
        rc=$(cat "$logs/shard-$k.rc" 2>/dev/null || echo "none")
        case $rc in
            0) ;;
            none) failed+=("shard $k (did not finish)") ;;
            *) failed+=("shard $k (exit status $rc)") ;;
        esac
    done
    if [ ${#failed[@]} -gt 0 ]; then
        echo "eval-array.sh: no merge: ${failed[*]}; see $logs/shard-K-*.out, rerun each failed shard K with" >&2
        echo "  sbatch --array=K --output=$logs/shard-%a-%A.out --open-mode=append $script $dataset $out $shards -- EVAL-OPTIONS" >&2
        echo "and then the merge alone with" >&2
        echo "  sbatch --export=ALL,MAPVLM_STAGE=merge --output=$logs/merge-%j.out $script $dataset $out $shards" >&2
        exit 1
    fi
    exec "$mapvlm" merge "${dirs[@]}" --out "$out/merged"
fi

mkdir -p "$logs"
array_range=1-$shards${throttle:+%$throttle}
array=$(sbatch --parsable "${sbatch_options[@]}" --array="$array_range" \
    --output="$logs/shard-%a-%A.out" --open-mode=append \
    "$script" "$dataset" "$out" "$shards" -- "$@")
array=${array%%;*}
merge=$(sbatch --parsable "${sbatch_options[@]}" --dependency="afterany:$array" \
    --job-name=mapvlm-merge --output="$logs/merge-%j.out" \
    --export="ALL,MAPVLM_STAGE=merge" "$script" "$dataset" "$out" "$shards")
echo "submitted array job $array (shards 1-$shards) and merge job ${merge%%;*} into $out/merged; logs in $logs"
