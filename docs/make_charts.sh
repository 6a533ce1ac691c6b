#!/usr/bin/env bash
# make_charts.sh [BUILD_DIR]
# Speed against accuracy: regenerates docs/charts/SCENE.svg (error against milliseconds per step,
# log-log, one series per method) and the results table in docs/benchmarks.md (between the
# markers <!-- charts:begin --> and <!-- charts:end -->).
#
# For each scene docs/charts/SCENE.json (a stiff cantilever, a soft drop on the ground, a
# twisting limb) it bakes the scene's surface with several handle counts, linear and quadratic
# (same surface and tet size, so the surface vertices correspond), runs
#   the reference:   full-space PD with exact projections, converged to REF_TOLERANCE per step
#                    (time.tolerance: the iterate estimated within that fraction of the
#                    diagonal of the converged step, mass-weighted RMS; at most REF_ITERATIONS
#                    iterations), and the same at ten times the tolerance, whose distance to it
#                    is reported as the reference's own error,
#   full-space PD:   at each of FULL_ITERATIONS,
#   reduced methods: each of REDUCED_METHODS (SOLVER:QUADRATIC) on each handle count of HANDLES
#                    at each of REDUCED_ITERATIONS (default the scene's 10; a count other than
#                    10 is its own series),
#   Anderson:        full-space PD with solver.acceleration "anderson" at each of
#                    ANDERSON_ITERATIONS, and each of ANDERSON_METHODS (SOLVER:QUADRATIC) on each
#                    handle count at 10 iterations (docs/method.md, "Accelerated iterations"),
# with `mat-run --stats --reference`, and collects ms per step (local + rhs + solve +
# reconstruct + contact + acceleration, one thread: export and measures excluded) and the RMS and max surface
# distance to the reference (% of the bounding-box diagonal, max over frames) into
# WORK/results.csv; then tests/bench/speed_accuracy_chart writes the SVGs and the table.
#
#   docs/make_charts.sh                      tools from build/ (needs the speed_accuracy_chart
#                                            target: -DMAT_BUILD_BENCHMARKS=ON)
#   docs/make_charts.sh build-release
#   CHARTS_WORK=/tmp/charts docs/make_charts.sh   work directory (bakes, runs; default BUILD/charts)
#   CHARTS_ONLY=1 docs/make_charts.sh        only redraw the charts and table from WORK/results.csv
#   CHARTS_DIR=docs/charts_50k MARKER=charts_50k TET_SIZE=0.0173 HANDLES="25 50 100 200" \
#       THREADS=2 docs/make_charts.sh        the same study on bodies of about 50k tets, into its
#                                            own charts and its own section of benchmarks.md
#                                            (between <!-- MARKER:begin --> and <!-- MARKER:end -->)
# Environment overrides: MAT_BAKE, MAT_RUN, MAT_CHART (tool paths), REF_TOLERANCE, REF_ITERATIONS,
# REF_ACCELERATION (none; "anderson" converges the reference in fewer iterations), FULL_ITERATIONS,
# HANDLES, REDUCED_METHODS, REDUCED_ITERATIONS, ANDERSON_ITERATIONS, ANDERSON_METHODS, SCENES
# (NAME:SURFACE[:TET_SIZE[:COUNTS]] entries, COUNTS a comma list of handle counts replacing
# HANDLES for the scene), THREADS (default 1), REF_THREADS (the untimed reference runs';
# default THREADS), TET_SIZE (0.04, for a scene without its own), DURATION (the scenes' own 1.5 s
# unless set), MEDIAL_QUERY_BOUND (mat-bake's default unless set: many spheres need more),
# QUADRATIC_MAX_HANDLES (quadratic bakes only up to this many handles; default all), GPU_METHODS
# (semi:QUADRATIC entries also run with --device cuda, their ms per step the GPU step's with the
# positions brought back every frame; default none), CHARTS_DIR (docs/charts, relative to the
# repository), MARKER (charts).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
bake="${MAT_BAKE:-$build/preprocess/mat-bake}"
run="${MAT_RUN:-$build/runtime/mat-run}"
chart="${MAT_CHART:-$build/tests/bench/speed_accuracy_chart}"
charts_dir="${CHARTS_DIR:-docs/charts}"
marker="${MARKER:-charts}"
work="${CHARTS_WORK:-$build/$(basename "$charts_dir")}"
threads="${THREADS:-1}"
ref_threads="${REF_THREADS:-$threads}" # the references' runs are not timed
for tool in "$bake" "$run" "$chart"; do
    [ -x "$tool" ] || { echo "make_charts: no $tool (build it, or pass the build directory)" >&2; exit 1; }
done

# The data: what is run. The reference is converged by a tolerance (docs/method.md, "Iterations
# to a tolerance"); the last full-space point (200 iterations) shows how far a fixed count is.
REF_TOLERANCE="${REF_TOLERANCE:-1e-9}"
REF_ITERATIONS="${REF_ITERATIONS:-3000}"
REF_ACCELERATION="${REF_ACCELERATION:-none}"
FULL_ITERATIONS="${FULL_ITERATIONS:-1 2 5 10 20 50 100 200}"
HANDLES="${HANDLES:-4 8 16 24}"
REDUCED_METHODS="${REDUCED_METHODS:-semi:none semi:all hyper:none hyper:all}"
REDUCED_ITERATIONS="${REDUCED_ITERATIONS:-10}"
ANDERSON_ITERATIONS="${ANDERSON_ITERATIONS:-5 10 15 20}"
ANDERSON_METHODS="${ANDERSON_METHODS:-semi:all hyper:all}"
# scene:surface[:tet size[:handle counts]] (surface relative to the repository), baked with tets
# of that size of the diagonal (TET_SIZE where none is given) and those handle counts (a comma
# list; HANDLES where none is given).
SCENES="${SCENES:-cantilever:samples/rounded_bar/rounded_bar.obj soft_drop:samples/torus/torus.obj twisting_limb:samples/capsule/capsule.obj}"
TET_SIZE="${TET_SIZE:-0.04}"
DURATION="${DURATION:-}"
MEDIAL_QUERY_BOUND="${MEDIAL_QUERY_BOUND:-}"
QUADRATIC_MAX_HANDLES="${QUADRATIC_MAX_HANDLES:-}"
GPU_METHODS="${GPU_METHODS:-}" # e.g. "semi:none semi:all" (a -DMAT_CUDA=ON build and a GPU)

# Reduced solvers this mat-run has (hyper slots in once `--solver hyper` is accepted).
solver_available() {
    "$run" --help | grep -A1 -- '--solver' | grep -q "$1"
}
method_label() { # SOLVER QUADRATIC [ACCELERATION [ITERATIONS]]
    local name suffix=""
    if [ "${3:-none}" = anderson ]; then suffix=" + Anderson"; fi
    if [ "${4:-10}" != 10 ]; then suffix="$suffix at $4 iterations"; fi
    case "$1" in
        semi) name="semi-reduced PD" ;;
        hyper) name="hyper-reduced PD" ;;
        *) name="$1" ;;
    esac
    if [ "$2" = all ]; then echo "$name (quadratic)$suffix"; else echo "$name (linear)$suffix"; fi
}

# ms per step (solver phases) and the reference error from a --stats file: "ms rms max".
read_stats() {
    awk '
        /"ms_per_step": \{/ { inside = 1; next }
        inside && /\}/ { inside = 0 }
        inside && /"(local|rhs|solve|reconstruct|contact|acceleration|device)":/ { gsub(/[",]/, ""); ms += $2 }
        /"rms_percent":/ { gsub(/[",]/, ""); rms = $2 }
        /"max_percent":/ { gsub(/[",]/, ""); max = $2 }
        END { if (rms == "" || max == "") exit 1; printf "%.6g %.6g %.6g\n", ms, rms, max }
    ' "$1"
}

# scene_copy SCENE_JSON BAKE ITERATIONS OUT [ACCELERATION [TOLERANCE [PROJECTIONS]]]: the scene
# with its bake and iterations replaced (and solver.acceleration, time.tolerance and
# solver.projections set, and time.duration if DURATION is). Self collision is off: the study
# measures the elastic solvers, and none of its bodies reaches itself.
scene_copy() {
    local duration=()
    if [ -n "$DURATION" ]; then duration=(-e "s|\"duration\": *[0-9.eE+-]*|\"duration\": $DURATION|"); fi
    sed -e "s|\"bake\": *\"[^\"]*\"|\"bake\": \"$2\"|" "${duration[@]}" \
        -e "s|\"iterations\": *[0-9]*|\"iterations\": $3, \"tolerance\": ${6:-0}|" \
        -e "s|\"output\":|\"solver\": { \"acceleration\": \"${5:-none}\", \"projections\": \"${7:-fast}\", \"self_collision\": \"off\" }, \"output\":|" \
        "$1" > "$4"
    grep -q "\"bake\": \"$2\"" "$4" || { echo "make_charts: could not set the bake in $4" >&2; exit 1; }
    [ -z "$DURATION" ] || grep -q "\"duration\": $DURATION" "$4" \
        || { echo "make_charts: could not set the duration in $4" >&2; exit 1; }
}

mkdir -p "$work"
csv="$work/results.csv"
ref_iterations=""
start_all=$(date +%s)
if [ -n "${CHARTS_ONLY:-}" ]; then
    [ -s "$csv" ] || { echo "make_charts: CHARTS_ONLY: no $csv (run once without it)" >&2; exit 1; }
else
echo "scene,method,parameter,value,ms_per_step,rms_percent,max_percent" > "$csv.tmp"
for entry in $SCENES; do
    IFS=: read -r scene surface tet_size scene_handles <<< "$entry"
    surface="$root/$surface"; tet_size="${tet_size:-$TET_SIZE}"
    handles="${scene_handles//,/ }"; handles="${handles:-$HANDLES}"
    json="$root/docs/charts/$scene.json"
    dir="$work/$scene"
    mkdir -p "$dir"
    echo "make_charts: $scene"
    # Bakes: every handle count, linear and quadratic, from one medial mesh per count
    # (`mat-bake medial`: the same mesh as `mat-bake --spheres N`, generated once). A count the
    # surface cannot carry (the generator stops, or the bake reports a rank-deficient basis) is
    # left out with a note.
    baked=""
    for n in $handles; do
        medial="$dir/medial_$n.ma"
        if [ ! -s "$medial" ] || [ "$medial" -ot "$surface" ]; then
            if ! "$bake" medial "$surface" --spheres "$n" --samples 5000 -o "$medial" \
                ${MEDIAL_QUERY_BOUND:+--medial-query-bound "$MEDIAL_QUERY_BOUND"} \
                > "$dir/medial_$n.log" 2>&1; then
                echo "make_charts:   $n handles left out: $(tail -1 "$dir/medial_$n.log")"
                continue
            fi
        fi
        for q in none all; do
            if [ "$q" = all ] && [ -n "$QUADRATIC_MAX_HANDLES" ] && [ "$n" -gt "$QUADRATIC_MAX_HANDLES" ]; then
                echo "make_charts:   $n quadratic handles left out: over QUADRATIC_MAX_HANDLES ($QUADRATIC_MAX_HANDLES; $((10 * n)) basis columns, a dense reduced system of that size)"
                continue
            fi
            out="$dir/bake_${tet_size}_${n}_$q.h5"
            if [ ! -s "$out" ] || [ "$out" -ot "$medial" ]; then
                if ! "$bake" "$surface" --medial "$medial" --tet-size "$tet_size" \
                    --quadratic "$q" -o "$out" --threads "$threads" --log-level warn \
                    > "$dir/bake_${n}_$q.log" 2>&1; then
                    echo "make_charts:   $n handles ($q quadratic) left out: $(tail -1 "$dir/bake_${n}_$q.log")"
                    continue
                fi
            fi
            baked="$baked ${n}_$q"
        done
    done
    first="$(echo $baked | cut -d' ' -f1)"
    [ -n "$first" ] || { echo "make_charts: $scene: no bake succeeded" >&2; exit 1; }
    full_bake="$dir/bake_${tet_size}_$first.h5"
    tets="$(awk '/^tets:/ { print $2; exit }' "$dir/bake_$first.log")"

    # The reference (full-space to REF_TOLERANCE), written as h5 by the scene's own output.
    # It is kept between runs of this script while the scene, the bake and mat-run are older.
    ref="reference_${REF_TOLERANCE}_${REF_ITERATIONS}_$REF_ACCELERATION"
    reference="$dir/$ref/trajectory.h5"
    scene_copy "$json" "$full_bake" "$REF_ITERATIONS" "$dir/$ref.json" "$REF_ACCELERATION" \
        "$REF_TOLERANCE" exact
    if [ ! -s "$reference" ] || [ ! -s "$dir/$ref.stats.json" ] || [ "$reference" -ot "$json" ] \
        || [ "$reference" -ot "$full_bake" ] || [ "$reference" -ot "$run" ]; then
        "$run" "$dir/$ref.json" -o "$dir/$ref" --solver full --threads "$ref_threads" \
            --log-level warn --stats "$dir/$ref.stats.json" > "$dir/$ref.log"
    fi
    # Its mean iterations per step (one body: the frames' iterations over the steps), and its
    # own error: the distance of the same run at ten times the tolerance.
    mean_iterations="$(awk '
        /^ "steps":/ { gsub(/[",]/, ""); steps = $2 }
        /^   "iterations":/ { gsub(/[",]/, ""); sum += $2 }
        END { printf "%.0f", sum / steps }' "$dir/$ref.stats.json")"
    loose="$(awk -v t="$REF_TOLERANCE" 'BEGIN { printf "%g", 10 * t }')"
    check="reference_loose_${loose}_${REF_ITERATIONS}_$REF_ACCELERATION" # kept, like the reference
    if [ ! -s "$dir/$check.stats.json" ] || [ "$dir/$check.stats.json" -ot "$reference" ]; then
        scene_copy "$json" "$full_bake" "$REF_ITERATIONS" "$dir/$check.json" "$REF_ACCELERATION" \
            "$loose" exact
        "$run" "$dir/$check.json" -o "$dir/$check" --solver full --threads "$ref_threads" \
            --log-level warn --reference "$reference" --stats "$dir/$check.stats.json" \
            > "$dir/$check.log"
    fi
    loose_rms="$(read_stats "$dir/$check.stats.json" | awk '{ printf "%.2g", $2 }')"
    ref_iterations="$ref_iterations $scene ($tets tets, size $tet_size) $mean_iterations iterations per step, $loose_rms% at $loose;"
    echo "make_charts:   reference: $mean_iterations iterations per step on average; at $loose it is $loose_rms% RMS off"

    # run_one METHOD PARAMETER VALUE SOLVER BAKE ITERATIONS NAME [ACCELERATION [DEVICE]]
    run_one() {
        scene_copy "$json" "$5" "$6" "$dir/$7.json" "${8:-none}"
        "$run" "$dir/$7.json" -o "$dir/$7" --solver "$4" --device "${9:-cpu}" \
            --threads "$threads" --log-level warn \
            --reference "$reference" --stats "$dir/$7.stats.json" > "$dir/$7.log" 2>&1 \
            || { echo "make_charts: $dir/$7.log: $(tail -1 "$dir/$7.log")" >&2; exit 1; }
        local stats
        stats="$(read_stats "$dir/$7.stats.json")" \
            || { echo "make_charts: $dir/$7.stats.json: no timings or reference error" >&2; exit 1; }
        set -- "$1" "$2" "$3" $stats
        echo "$scene,$1,$2,$3,$4,$5,$6" >> "$csv.tmp"
        printf 'make_charts:   %-28s %-10s %4s  %9.3f ms/step  RMS %8.4f%%  max %8.4f%%\n' \
            "$1" "$2" "$3" "$4" "$5" "$6"
    }
    for it in $FULL_ITERATIONS; do
        run_one "full-space PD" iterations "$it" full "$full_bake" "$it" "full_$it"
    done
    for it in $ANDERSON_ITERATIONS; do
        run_one "full-space PD + Anderson" iterations "$it" full "$full_bake" "$it" "full_anderson_$it" anderson
    done
    # reduced_runs METHODS ACCELERATION DEVICE ITERATIONS...: each method (SOLVER:QUADRATIC) on
    # each handle count at each iteration count, on the CPU or (DEVICE cuda) the GPU.
    reduced_runs() {
        local method solver q n it methods="$1" acceleration="$2" device="$3" name label
        shift 3
        for method in $methods; do
            solver="${method%%:*}"; q="${method#*:}"
            if ! solver_available "$solver"; then
                echo "make_charts:   $(method_label "$solver" "$q"): mat-run has no --solver $solver, left out"
                continue
            fi
            for it in "$@"; do
                for n in $handles; do
                    case " $baked " in *" ${n}_$q "*) ;; *) continue ;; esac
                    name="${solver}_${n}_${q}_$acceleration"
                    [ "$it" = 10 ] || name="${name}_$it"
                    label="$(method_label "$solver" "$q" "$acceleration" "$it")"
                    if [ "$device" = cuda ]; then name="${name}_gpu" label="$label on the GPU"; fi
                    run_one "$label" handles "$n" "$solver" "$dir/bake_${tet_size}_${n}_$q.h5" \
                        "$it" "$name" "$acceleration" "$device"
                done
            done
        done
    }
    reduced_runs "$REDUCED_METHODS" none cpu $REDUCED_ITERATIONS
    reduced_runs "$ANDERSON_METHODS" anderson cpu 10
    # The GPU step (semi-reduced, plain iterations: docs/gpu.md), where asked for.
    reduced_runs "$GPU_METHODS" none cuda $REDUCED_ITERATIONS
done
ref_label=""
if [ "$REF_ACCELERATION" = anderson ]; then ref_label=", Anderson-accelerated"; fi
# The charts' note, kept with the results for CHARTS_ONLY.
echo "reference: full-space PD, exact projections$ref_label, converged per step to an estimated $REF_TOLERANCE of the diagonal (time.tolerance;${ref_iterations%;}); ms per step with $threads thread(s)" > "$work/note.txt"
mv "$csv.tmp" "$csv"
fi

# The charts and the table; the table replaces docs/benchmarks.md's between the markers.
mkdir -p "$root/$charts_dir"
"$chart" "$csv" "$root/$charts_dir" "$work/table.md" --link-dir "${charts_dir#docs/}" \
    --note "$(cat "$work/note.txt" 2> /dev/null || true)"
doc="$root/docs/benchmarks.md"
grep -q "^<!-- $marker:begin -->\$" "$doc" && grep -q "^<!-- $marker:end -->\$" "$doc" \
    || { echo "make_charts: $doc has no <!-- $marker:begin --> / <!-- $marker:end --> lines" >&2; exit 1; }
awk -v table="$work/table.md" -v begin="<!-- $marker:begin -->" -v end="<!-- $marker:end -->" '
    $0 == begin { print; while ((getline line < table) > 0) print line; skip = 1; next }
    $0 == end { skip = 0 }
    !skip { print }
' "$doc" > "$doc.tmp"
mv "$doc.tmp" "$doc"
echo "make_charts: wrote $charts_dir/*.svg, $csv and the table in docs/benchmarks.md in $(( $(date +%s) - start_all )) s"
