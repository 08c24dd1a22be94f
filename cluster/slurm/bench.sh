#!/usr/bin/env bash
# Spread a `lodestar bench` over a Slurm job array and build its report (run on a login node).
#
# usage: cluster/slurm/bench.sh -n PARTS -o OUTDIR -- BENCH_ARGS...
#
# BENCH_ARGS: everything for `lodestar bench` (--scene, --integrators, --time, --reference,
# --runs, ...) except --part, --from-parts and --out. Submits with `sbatch --parsable`:
#   1. an array --array=1-PARTS, task I running
#      bench BENCH_ARGS --part I/PARTS --out OUTDIR/part-I   (its share of integrator x seed)
#   2. a report job (afterok on the array):
#      bench BENCH_ARGS --from-parts OUTDIR/part-1 .. OUTDIR/part-PARTS --out OUTDIR
# Give --threads in BENCH_ARGS to match SBATCH_CPUS_PER_TASK: the time budget is per render,
# so a comparison is fair only when every task runs its renders alike. The binary is
# $LODESTAR (default: lodestar on PATH). Prints the job ids.
set -euo pipefail
die() { echo "bench.sh: $*" >&2; exit 2; }
usage="usage: bench.sh -n PARTS -o OUTDIR -- BENCH_ARGS..."
parts='' out=''
while getopts n:o: opt; do
    case $opt in
        n) parts=$OPTARG ;;
        o) out=$OPTARG ;;
        *) die "$usage" ;;
    esac
done
shift $((OPTIND - 1))
[[ $parts =~ ^[1-9][0-9]*$ ]] || die "-n PARTS: a whole number >= 1 is required. $usage"
[[ -n $out ]] || die "-o OUTDIR is required. $usage"
for a in "$@"; do
    case $a in
        --part | --part=* | --from-parts | --from-parts=* | --out | --out=*) die "BENCH_ARGS must not give $a" ;;
    esac
done
mkdir -p -- "$out"
out=$(cd -- "$out" && pwd)
lodestar=${LODESTAR:-lodestar}
q() { printf '%q ' "$@"; }
sub() { local j; j=$(sbatch --parsable "$@") || exit 1; echo "${j%%;*}"; }

# The task's index is expanded by the task's shell, not here.
task="$(q "$lodestar" bench "$@") --part \"\$SLURM_ARRAY_TASK_ID/$parts\" --out $(printf %q "$out")/part-\"\$SLURM_ARRAY_TASK_ID\""
array=$(sub -J lodestar-bench --array="1-$parts" -o "$out/part-%a.log" --wrap "$task")
echo "array job $array: $parts parts in $out/part-I"
dirs=()
for ((i = 1; i <= parts; i++)); do dirs+=("$out/part-$i"); done
report=$(sub -J lodestar-bench-report --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    -o "$out/report.log" --wrap "$(q "$lodestar" bench "$@" --from-parts "${dirs[@]}" --out)$(printf %q "$out")")
echo "report job $report: $out/index.html"
