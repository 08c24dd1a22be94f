#!/bin/sh
# CPU-seconds per 512 x 512 iteration of SmallVCM's bpt and vcm against lodestar's bdpt and vcm
# on SmallVCM's default Cornell box (benches/scenes/smallvcm-cornell.toml), side by side.
#
#   benches/reference/smallvcm_iterations.sh SMALLVCM_CHECKOUT [ITERATIONS] [THREADS]
#
# SMALLVCM_CHECKOUT: a clone of github.com/SmallVCM/SmallVCM. Its scene list
# (g_SceneConfigs in src/config.hxx) lacks the default box (Scene::kDefault), so this script
# appends it (scene index 4) and builds with the Makefile (g++ -O3 -fopenmp). CPU seconds are
# user + system time of the whole process (/usr/bin/time), for both renderers; lodestar's
# include loading the scene (about 0.01 s). Image means: lodestar prints its own; SmallVCM's
# .hdr is RGBE, whose mantissas are truncated (about -0.3 %), so dequantise at bin centres.
set -e
SVCM=${1:?usage: $0 SMALLVCM_CHECKOUT [ITERATIONS] [THREADS]}
N=${2:-4}
T=${3:-2}
HERE=$(cd "$(dirname "$0")/../.." && pwd)
if ! grep -q 'Scene::kDefault$' "$SVCM/src/config.hxx"; then
    sed -i 's/    Scene::kGlossyFloor | Scene::kBothSmallSpheres  | Scene::kLightBackground$/    Scene::kGlossyFloor | Scene::kBothSmallSpheres  | Scene::kLightBackground,\n    Scene::kDefault/' "$SVCM/src/config.hxx"
fi
(cd "$SVCM" && make >/dev/null)
(cd "$HERE" && cargo build --profile timed -q)
for round in 1 2 3; do
    for a in bpt vcm; do
        OMP_NUM_THREADS=$T /usr/bin/time -f "smallvcm $a: %U user + %S sys s for $N iterations" \
            "$SVCM/smallvcm" -s 4 -a $a -i "$N" -o "/tmp/smallvcm-$a.hdr" >/dev/null
    done
    # bdpt's roulette is SmallVCM's (continuation = the largest reflectance from the first
    # bounce on, as vcm does); "bdpt rr_depth=5" waits 5 segments, as pt does.
    for a in bdpt "bdpt rr_depth=5" vcm; do
        set -- $a
        opt=${2:+-O $2}
        /usr/bin/time -f "lodestar $a: %U user + %S sys s for $N iterations" \
            "$HERE/target/timed/lodestar" render "$HERE/benches/scenes/smallvcm-cornell.toml" \
            --integrator $1 $opt --spp "$N" --threads "$T" --max-depth 10 -q -o "/tmp/lodestar-smallvcm-$1.exr"
    done
done
