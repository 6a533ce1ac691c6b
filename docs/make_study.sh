#!/usr/bin/env bash
# make_study.sh [BUILD_DIR] [PRESET]
# The speed-against-accuracy study in one command (docs/benchmarks.md, "Speed against accuracy"):
# docs/make_charts.sh on each body size, each into its own charts (docs/charts*/SCENE.svg) and its
# own section of docs/benchmarks.md. PRESET:
#   quick  the three scenes at about 2k tets (tet size 0.04), every method, 1 thread
#          (docs/charts; a few minutes on 2 cores)
#   50k    the same at about 50k tets (0.0173), 25 to 200 handles, 2 threads (docs/charts_50k)
#   400k   the cantilever and the twisting limb at 400k tets or more (sizes per scene), 25 to
#          1000 handles (the limb 25 and 100: 1000 spheres on a capsule's medial segment take the
#          generator minutes), and a real mesh, the armadillo of libcgal-demo swaying on pinned
#          feet (25 and 100 handles; samples/meshes/armadillo.off, which .ci/install-deps.sh
#          extracts), iterations 5 to 50 for the reduced methods too, the first 0.5 s of each
#          scene, an Anderson-accelerated reference, 2 threads (docs/charts_400k; the soft drop's
#          full-space contacts are too slow at this size, docs/benchmarks.md)
#   all    quick, 50k and 400k (the default)
# The timed runs use the threads above whatever the machine has; the references, which are not
# timed, use every core (REF_THREADS, default `nproc`), so a many-core machine shortens them.
# Work directories: BUILD_DIR/charts, BUILD_DIR/charts_50k, BUILD_DIR/charts_400k (bakes,
# references and runs are kept and reused while current).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
preset="${2:-all}"
case "$preset" in quick | 50k | 400k | all) ;; *)
    echo "make_study: unknown preset '$preset' (quick, 50k, 400k or all)" >&2
    exit 2
    ;;
esac
export REF_THREADS="${REF_THREADS:-$(nproc)}"
armadillo=samples/meshes/armadillo.off
if { [ "$preset" = 400k ] || [ "$preset" = all ]; } && [ ! -s "$root/$armadillo" ]; then
    echo "make_study: $root/$armadillo: missing (the 400k section's real mesh; .ci/install-deps.sh extracts it from libcgal-demo)" >&2
    exit 1
fi
start=$(date +%s)
part() { # NAME, then the environment of make_charts.sh
    local name="$1" begin
    shift
    begin=$(date +%s)
    echo "make_study: $name"
    env "$@" "$root/docs/make_charts.sh" "$build"
    echo "make_study: $name took $(($(date +%s) - begin)) s"
}
if [ "$preset" = quick ] || [ "$preset" = all ]; then
    part "about 2k tets" CHARTS_WORK="$build/charts"
fi
if [ "$preset" = 50k ] || [ "$preset" = all ]; then
    part "about 50k tets" CHARTS_DIR=docs/charts_50k MARKER=charts_50k CHARTS_WORK="$build/charts_50k" \
        TET_SIZE=0.0173 HANDLES="25 50 100 200" THREADS=2 FULL_ITERATIONS="1 2 5 10 20 50"
fi
if [ "$preset" = 400k ] || [ "$preset" = all ]; then
    part "400k tets or more" CHARTS_DIR=docs/charts_400k MARKER=charts_400k \
        CHARTS_WORK="$build/charts_400k" THREADS=2 DURATION=0.5 REF_ACCELERATION=anderson \
        SCENES="cantilever:samples/rounded_bar/rounded_bar.obj:0.0085 twisting_limb:samples/capsule/capsule.obj:0.0076:25,100 armadillo_sway:$armadillo:0.0060:25,100" \
        HANDLES="25 100 1000" MEDIAL_QUERY_BOUND=2000 QUADRATIC_MAX_HANDLES=100 \
        FULL_ITERATIONS="5 10 20 50" ANDERSON_ITERATIONS="5 10 20" \
        REDUCED_METHODS="semi:none semi:all hyper:none hyper:all" REDUCED_ITERATIONS="10 5 20 50" \
        ANDERSON_METHODS="semi:all hyper:all"
fi
echo "make_study: $preset in $(($(date +%s) - start)) s"
