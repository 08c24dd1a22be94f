#!/bin/sh
# One part of a lodestar render, run as a Slurm array task (submit.sh submits it).
#
# usage: part.sh [-n PARTS] [-d WORKDIR] [--] RENDER_ARGS...
#
# The part index I comes from SLURM_ARRAY_TASK_ID (1..PARTS), PARTS from -n or
# $LODESTAR_PARTS, WORKDIR from -d or $LODESTAR_WORKDIR (default: .). Runs
#   $LODESTAR render RENDER_ARGS --part I/PARTS -o WORKDIR/part-I.exr
# ($LODESTAR defaults to lodestar on PATH), adding --load-guides WORKDIR/guides.bin for
# --integrator guided-pt|guided-bdpt and --threads $SLURM_CPUS_PER_TASK when Slurm sets it
# (unless RENDER_ARGS already give them).
set -eu
die() { echo "part.sh: $*" >&2; exit 2; }
parts=${LODESTAR_PARTS:-} work=${LODESTAR_WORKDIR:-.}
while getopts n:d: opt; do
    case $opt in
        n) parts=$OPTARG ;;
        d) work=$OPTARG ;;
        *) die "usage: part.sh [-n PARTS] [-d WORKDIR] [--] RENDER_ARGS..." ;;
    esac
done
shift $((OPTIND - 1))

id=${SLURM_ARRAY_TASK_ID:-}
[ -n "$id" ] || die "SLURM_ARRAY_TASK_ID is not set: run this as a Slurm array task" \
    "(sbatch --array=1-PARTS), or set SLURM_ARRAY_TASK_ID=I by hand"
case $parts in '' | *[!0-9]*) die "part count missing or not a number: give -n PARTS or set LODESTAR_PARTS" ;; esac
case $id in *[!0-9]*) die "SLURM_ARRAY_TASK_ID='$id' is not a number" ;; esac
[ "$id" -ge 1 ] && [ "$id" -le "$parts" ] ||
    die "SLURM_ARRAY_TASK_ID=$id is outside 1..$parts (submit with --array=1-$parts)"

guided= loaded= threads= prev=
for a in "$@"; do
    case $prev/$a in --integrator/guided-pt | --integrator/guided-bdpt) guided=1 ;; esac
    case $a in
        --integrator=guided-pt | --integrator=guided-bdpt) guided=1 ;;
        --load-guides | --load-guides=*) loaded=1 ;;
        --threads | --threads=*) threads=1 ;;
    esac
    prev=$a
done
if [ -n "$guided" ] && [ -z "$loaded" ]; then
    set -- "$@" --load-guides "$work/guides.bin"
fi
if [ -z "$threads" ] && [ -n "${SLURM_CPUS_PER_TASK:-}" ]; then
    set -- "$@" --threads "$SLURM_CPUS_PER_TASK"
fi
exec "${LODESTAR:-lodestar}" render "$@" --part "$id/$parts" -o "$work/part-$id.exr"
