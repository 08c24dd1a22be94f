#!/usr/bin/env bash
# Render one lodestar image as a Slurm job array and merge the parts (run on a login node).
#
# usage: cluster/slurm/submit.sh -n PARTS -o OUT.exr [-d WORKDIR] [-p OUT.png] -- RENDER_ARGS...
#
# RENDER_ARGS: everything for `lodestar render` (scene, --spp, --seed, ...) except --part and
# -o; --spp is required. Submits with `sbatch --parsable`:
#   1. only for --integrator guided-pt|guided-bdpt: a learning job,
#      render RENDER_ARGS --save-guides WORKDIR/guides.bin -o WORKDIR/learn.exr
#   2. an array --array=1-PARTS (afterok on 1) of part.sh tasks writing WORKDIR/part-I.exr
#   3. a merge job (afterok on the array): merge WORKDIR/part-{1..PARTS}.exr -o OUT.exr
# WORKDIR defaults to OUT's directory; logs go there too. The binary is $LODESTAR (default:
# lodestar on PATH). More sbatch options through its environment, e.g. SBATCH_PARTITION,
# SBATCH_CPUS_PER_TASK (part.sh then passes --threads), SBATCH_TIMELIMIT. Prints the job ids.
set -euo pipefail
die() { echo "submit.sh: $*" >&2; exit 2; }
usage="usage: submit.sh -n PARTS -o OUT.exr [-d WORKDIR] [-p OUT.png] -- RENDER_ARGS..."
parts='' out='' work='' png=''
while getopts n:o:d:p: opt; do
    case $opt in
        n) parts=$OPTARG ;;
        o) out=$OPTARG ;;
        d) work=$OPTARG ;;
        p) png=$OPTARG ;;
        *) die "$usage" ;;
    esac
done
shift $((OPTIND - 1))
[[ $parts =~ ^[1-9][0-9]*$ ]] || die "-n PARTS: a whole number >= 1 is required. $usage"
[[ -n $out ]] || die "-o OUT.exr is required. $usage"
guided='' loaded='' spp='' prev=''
for a in "$@"; do
    case $prev/$a in --integrator/guided-pt | --integrator/guided-bdpt) guided=1 ;; esac
    case $a in
        --integrator=guided-pt | --integrator=guided-bdpt) guided=1 ;;
        --load-guides | --load-guides=*) loaded=1 ;;
        --spp | --spp=*) spp=1 ;;
        --part | --part=* | -o | -o* | --output | --output=*) die "RENDER_ARGS must not give $a" ;;
    esac
    prev=$a
done
[[ -n $spp ]] || die "RENDER_ARGS must give --spp (parts split the passes). $usage"

work=${work:-$(dirname -- "$out")}
mkdir -p -- "$work" "$(dirname -- "$out")"
work=$(cd -- "$work" && pwd)
[[ $out == /* ]] || out=$PWD/$out
lodestar=${LODESTAR:-lodestar}
export LODESTAR=$lodestar
q() { printf '%q ' "$@"; }
sub() { local j; j=$(sbatch --parsable "$@") || exit 1; echo "${j%%;*}"; }

dep=()
if [[ -n $guided && -z $loaded ]]; then
    learn=$(sub -J lodestar-learn -o "$work/learn.log" \
        --wrap "$(q "$lodestar" render "$@" --save-guides "$work/guides.bin" -o "$work/learn.exr")")
    echo "learning job $learn: $work/guides.bin"
    dep=(--dependency="afterok:$learn" --kill-on-invalid-dep=yes)
fi
array=$(sub -J lodestar-part --array="1-$parts" ${dep[@]+"${dep[@]}"} -o "$work/part-%a.log" \
    "$(dirname -- "$0")/part.sh" -n "$parts" -d "$work" -- "$@")
echo "array job $array: $parts parts, $work/part-I.exr"
files=()
for ((i = 1; i <= parts; i++)); do files+=("$work/part-$i.exr"); done
merge=("$lodestar" merge "${files[@]}" -o "$out")
[[ -z $png ]] || merge+=(--png "$png")
m=$(sub -J lodestar-merge --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    -o "$work/merge.log" --wrap "$(q "${merge[@]}")")
echo "merge job $m: $out"
