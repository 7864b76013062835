#!/usr/bin/env bash
# Waits for a Kubernetes Job to end, either way: exits 0 once job/JOB is
# complete, 1 as soon as it has failed (naming its failed indexes, for an
# Indexed Job), and 1 after TIMEOUT (default 24h) when neither happened.
# `kubectl wait --for=condition=complete` alone would wait the whole timeout
# for a Job that failed.
#
# usage: deploy/kubernetes/wait.sh JOB [TIMEOUT]
#   e.g. deploy/kubernetes/wait.sh mapvlm-eval 12h && kubectl apply -f deploy/kubernetes/merge-job.yaml
#
# $KUBECTL is the kubectl to run (default: kubectl on the PATH), with the
# usual context and namespace (KUBECONFIG, or add --namespace through a
# wrapper).
set -euo pipefail

if [ $# -lt 1 ] || [ $# -gt 2 ] || [ -z "$1" ]; then
    echo "usage: wait.sh JOB [TIMEOUT]" >&2
    echo "  e.g. wait.sh mapvlm-eval 12h" >&2
    exit 2
fi
job=$1
timeout=${2:-24h}
kubectl=${KUBECTL:-kubectl}

"$kubectl" wait --for=condition=complete --timeout="$timeout" "job/$job" >/dev/null &
complete=$!
"$kubectl" wait --for=condition=failed --timeout="$timeout" "job/$job" >/dev/null &
failed=$!
ended=0
wait -n "$complete" "$failed" || ended=$?
if kill -0 "$complete" 2>/dev/null; then
    # The wait for completion is still running: the other one ended first.
    kill "$complete" 2>/dev/null || true
    wait "$complete" 2>/dev/null || true
    if [ "$ended" -eq 0 ]; then
        indexes=$("$kubectl" get "job/$job" -o 'jsonpath={.status.failedIndexes}' 2>/dev/null || true)
        echo "wait.sh: job/$job failed${indexes:+ (failed indexes: $indexes; shard = index + 1)}; see kubectl logs job/$job and kubectl describe job/$job" >&2
    else
        echo "wait.sh: job/$job is neither complete nor failed after $timeout (or kubectl could not wait for it)" >&2
    fi
    exit 1
fi
kill "$failed" 2>/dev/null || true
wait "$failed" 2>/dev/null || true
if [ "$ended" -ne 0 ]; then
    echo "wait.sh: job/$job is neither complete nor failed after $timeout (or kubectl could not wait for it)" >&2
    exit 1
fi
echo "wait.sh: job/$job is complete"
