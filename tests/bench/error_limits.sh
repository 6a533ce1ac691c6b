#!/usr/bin/env bash
# error_limits.sh [BUILD_DIR]
# What limits the error of the reduced models in docs/make_charts.sh's charts
# (docs/benchmarks.md, "What limits the error"). On the same three scenes, surfaces and tet size
# as the charts, against the same reference (full-space PD at REF_ITERATIONS iterations), it runs
#   iterations:  semi-reduced PD, linear and quadratic, each handle count of HANDLES, at each of
#                ITERATIONS (the converged error is the subspace's own; the rest is iterations),
#                the last count also at twice CONVERGED (a check that CONVERGED is converged),
#                and full-space PD at ITERATIONS;
#   weights:     bakes keeping WEIGHTS_PER_NODE largest weights per node (all: every handle) for
#                the counts of WEIGHT_HANDLES, run at the scene's iterations and converged;
#   pins:        the pinned scenes with solver.reduced_pin_stiffness at each of PIN_SCALES
#                (semi-reduced, PIN_HANDLES handles) and solver.full_pin_stiffness at each of them
#                (full-space), at the scene's iterations and converged; and each converged
#                reduced run against full-space PD converged with the same pin stiffness.
# Each run's RMS and max surface distance to the reference (% of the bbox diagonal, max over
# frames) and solver ms per step (one thread, one run: indicative, not a benchmark) go to
# WORK/limits.csv, and the tables to WORK/limits.md. About 10 min on one core.
#
#   bash tests/bench/error_limits.sh build
#   LIMITS_WORK=/tmp/limits bash tests/bench/error_limits.sh build   (default BUILD/error_limits)
#   LIMITS_ONLY_TABLES=1 bash tests/bench/error_limits.sh build      tables from WORK/limits.csv
#   bash tests/bench/error_limits.sh build speed   the cost of weights per node instead: bake
#       seconds and ms per step (scene's iterations) of WEIGHT_SPEED_HANDLES quadratic and linear
#       handles at each of WEIGHTS_PER_NODE, ROUNDS rounds alternated, medians (one thread),
#       into WORK/weights_cost.md (about 4 min)
# Environment overrides: MAT_BAKE, MAT_RUN, SCENES, HANDLES, ITERATIONS, CONVERGED,
# REF_ITERATIONS, WEIGHT_HANDLES, WEIGHTS_PER_NODE, PIN_HANDLES, PIN_SCALES, ROUNDS,
# WEIGHT_SPEED_HANDLES.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
bake="${MAT_BAKE:-$build/preprocess/mat-bake}"
run="${MAT_RUN:-$build/runtime/mat-run}"
work="${LIMITS_WORK:-$build/error_limits}"
for tool in "$bake" "$run"; do
    [ -x "$tool" ] || { echo "error_limits: no $tool (build it, or pass the build directory)" >&2; exit 1; }
done

SCENES="${SCENES:-cantilever:samples/rounded_bar/rounded_bar.obj soft_drop:samples/torus/torus.obj twisting_limb:samples/capsule/capsule.obj}"
TET_SIZE=0.04 # the charts' tet size
REF_ITERATIONS="${REF_ITERATIONS:-400}"
HANDLES="${HANDLES:-4 8 16 24}"
ITERATIONS="${ITERATIONS:-10 50 200}"
CONVERGED="${CONVERGED:-200}" # the iteration count taken as converged
WEIGHT_HANDLES="${WEIGHT_HANDLES-16 24}" # empty: no weights study
WEIGHTS_PER_NODE="${WEIGHTS_PER_NODE:-8 16 all}"
PIN_HANDLES="${PIN_HANDLES:-24}"
PIN_SCALES="${PIN_SCALES-0.1 1 100 1e4 1e8}" # empty: no pin study
scene_iterations=10 # every chart scene's time.iterations
largest="${HANDLES##* }" # also run at twice CONVERGED, to check that CONVERGED is converged
check=$((2 * CONVERGED))

# "ms rms max drop" from a --stats file (ms: local + rhs + solve + reconstruct + contact; rms and
# max "-" without a reference; drop: the largest fall of the potential energy below frame 0's,
# J, i.e. how far the centre of mass sinks, times m g).
stats_of() {
    awk '
        /"ms_per_step": \{/ { timing = 1; next }
        timing && /\}/ { timing = 0 }
        timing && /"(local|rhs|solve|reconstruct|contact)":/ { gsub(/[",]/, ""); ms += $2 }
        /"rms_percent":/ { gsub(/[",]/, ""); rms = $2 }
        /"max_percent":/ { gsub(/[",]/, ""); mx = $2 }
        /"potential":/ { gsub(/[",]/, ""); if (p0 == "") p0 = $2; if (low == "" || $2 < low) low = $2 }
        END {
            if (p0 == "") exit 1
            if (rms == "") { rms = "-"; mx = "-" }
            printf "%.4g %s %s %.6g\n", ms, rms, mx, p0 - low
        }
    ' "$1"
}

# with_settings SCENE_JSON BAKE ITERATIONS SOLVER_JSON OUT: the scene with its bake, iterations
# and a "solver" object (SOLVER_JSON, may be empty, and self collision off, as in
# docs/make_charts.sh: the chart scenes' bodies never reach themselves) set.
with_settings() {
    sed -e "s|\"bake\": *\"[^\"]*\"|\"bake\": \"$2\"|" \
        -e "s|\"iterations\": *[0-9]*|\"iterations\": $3|" "$1" > "$5"
    sed -i -e "s|^\( *\)\"gravity\":|\1\"solver\": { ${4:+$4, }\"self_collision\": \"off\" },\n&|" "$5"
    grep -q "\"bake\": \"$2\"" "$5" || { echo "error_limits: could not set the bake in $5" >&2; exit 1; }
}

# bake_one SURFACE HANDLES QUADRATIC WEIGHTS OUT: bakes once (kept between runs) and prints the
# bake's wall time in seconds (of the bake that made the file; one thread).
bake_one() {
    if [ ! -s "$5" ] || [ "$5" -ot "$1" ]; then
        local start end
        start=$(date +%s.%N)
        "$bake" "$1" --spheres "$2" --samples 5000 --tet-size "$TET_SIZE" --quadratic "$3" \
            --weights-per-node "$4" --threads 1 -o "$5" --log-level warn > "$5.log" 2>&1 \
            || { echo "error_limits: bake $5 failed: $(tail -1 "$5.log")" >&2; exit 1; }
        end=$(date +%s.%N)
        awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f\n", b - a }' > "$5.seconds"
    fi
    cat "$5.seconds"
}

mkdir -p "$work"
work="$(cd "$work" && pwd)" # scenes name their bakes by absolute paths
if [ "${2:-}" = speed ]; then
    rounds="${ROUNDS:-5}"
    n="${WEIGHT_SPEED_HANDLES:-24}"
    out="$work/weights_cost.md"
    median() { sort -g "$1" | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
    echo "| scene | method | handles | weights per node | bake s | ms/step $scene_iterations it |" > "$out.tmp"
    echo "| --- | --- | ---: | ---: | ---: | ---: |" >> "$out.tmp"
    for entry in $SCENES; do
        scene="${entry%%:*}"; surface="$root/${entry#*:}"
        json="$root/docs/charts/$scene.json"
        dir="$work/speed/$scene"
        mkdir -p "$dir"
        for q in all none; do
            method=linear; [ "$q" = all ] && method=quadratic
            rm -f "$dir"/*.samples
            for ((r = 0; r < rounds; ++r)); do
                for w in $WEIGHTS_PER_NODE; do
                    [ "$w" = all ] && w="$n"
                    rm -f "$dir/bake_$w.h5"
                    bake_one "$surface" "$n" "$q" "$w" "$dir/bake_$w.h5" >> "$dir/bake_$w.samples"
                    with_settings "$json" "$dir/bake_$w.h5" "$scene_iterations" "" "$dir/run_$w.json"
                    "$run" "$dir/run_$w.json" -o "$dir/run_$w" --threads 1 --log-level warn \
                        --stats "$dir/run_$w.stats.json" > "$dir/run_$w.log"
                    set -- $(stats_of "$dir/run_$w.stats.json")
                    echo "$1" >> "$dir/ms_$w.samples"
                done
            done
            for w in $WEIGHTS_PER_NODE; do
                label="$w"; [ "$w" = all ] && w="$n" && label=all
                echo "| $scene | $method | $n | $label | $(median "$dir/bake_$w.samples") | $(median "$dir/ms_$w.samples") |" >> "$out.tmp"
            done
        done
    done
    mv "$out.tmp" "$out"
    echo "error_limits: wrote $out (medians of $rounds alternated rounds)"
    exit 0
fi
csv="$work/limits.csv"
if [ -z "${LIMITS_ONLY_TABLES:-}" ]; then
    echo "scene,study,method,handles,weights_per_node,pin_scale,iterations,bake_s,ms_per_step,rms_percent,max_percent,drop_j" > "$csv.tmp"
    for entry in $SCENES; do
        scene="${entry%%:*}"; surface="$root/${entry#*:}"
        json="$root/docs/charts/$scene.json"
        dir="$work/$scene"
        mkdir -p "$dir"
        pinned=0; grep -q '"pins"' "$json" && pinned=1
        echo "error_limits: $scene"

        # record STUDY METHOD HANDLES WEIGHTS PIN ITERATIONS BAKE_S SOLVER BAKE SOLVER_JSON NAME
        record() {
            with_settings "$json" "$9" "$6" "${10}" "$dir/${11}.json"
            "$run" "$dir/${11}.json" -o "$dir/${11}" --solver "$8" --threads 1 --log-level warn \
                --reference "$reference" --stats "$dir/${11}.stats.json" > "$dir/${11}.log"
            local stats
            stats="$(stats_of "$dir/${11}.stats.json")" && [ "${stats#* -}" = "$stats" ] \
                || { echo "error_limits: $dir/${11}.stats.json: no timings or error" >&2; exit 1; }
            set -- "$1" "$2" "$3" "$4" "$5" "$6" "$7" $stats
            echo "$scene,$1,$2,$3,$4,$5,$6,$7,$8,$9,${10},${11}" >> "$csv.tmp"
            printf 'error_limits:   %-8s %-9s %3s h  w %-3s  pin %-4s %4s it  %8.3f ms/step  RMS %8.4f%%  max %8.4f%%\n' \
                "$1" "$2" "$3" "$4" "$5" "$6" "$8" "$9" "${10}"
        }

        # The reference: full-space PD at REF_ITERATIONS on the first bake (every bake of a
        # scene has the same tets and surface).
        ref_bake="$dir/bake_4_none_w8.h5"
        bake_one "$surface" 4 none 8 "$ref_bake" > /dev/null
        reference="$dir/reference/trajectory.h5"
        with_settings "$json" "$ref_bake" "$REF_ITERATIONS" "" "$dir/reference.json"
        if [ ! -s "$reference" ] || [ ! -s "$dir/reference.stats.json" ] \
            || [ "$reference" -ot "$run" ] || [ "$reference" -ot "$json" ]; then
            "$run" "$dir/reference.json" -o "$dir/reference" --solver full --threads 1 \
                --log-level warn --stats "$dir/reference.stats.json" > "$dir/reference.log"
        fi
        set -- $(stats_of "$dir/reference.stats.json")
        echo "$scene,reference,full,-,8,-,$REF_ITERATIONS,-,$1,0,0,$4" >> "$csv.tmp"

        # Iterations against the subspace.
        for it in $ITERATIONS; do
            record iterations full - 8 - "$it" - full "$ref_bake" "" "full_$it"
        done
        for q in none all; do
            method=linear; [ "$q" = all ] && method=quadratic
            for n in $HANDLES; do
                seconds="$(bake_one "$surface" "$n" "$q" 8 "$dir/bake_${n}_${q}_w8.h5")"
                its="$ITERATIONS"; [ "$n" = "$largest" ] && its="$its $check"
                for it in $its; do
                    record iterations "$method" "$n" 8 - "$it" "$seconds" semi \
                        "$dir/bake_${n}_${q}_w8.h5" "" "semi_${n}_${q}_w8_$it"
                done
            done
        done

        # Weights kept per node (8 is the bake's default; with n <= 8 handles every weight is
        # kept already, so only counts above the default are baked again).
        for q in none all; do
            method=linear; [ "$q" = all ] && method=quadratic
            for n in $WEIGHT_HANDLES; do
                widths=" "
                for w in $WEIGHTS_PER_NODE; do
                    [ "$w" = all ] && w="$n"
                    [ "$w" -gt "$n" ] && w="$n"
                    case "$widths" in *" $w "*) continue ;; esac
                    widths="$widths$w "
                    label="$w"; [ "$w" = "$n" ] && label=all
                    out="$dir/bake_${n}_${q}_w$w.h5"
                    seconds="$(bake_one "$surface" "$n" "$q" "$w" "$out")"
                    for it in $scene_iterations $CONVERGED; do
                        record weights "$method" "$n" "$label" - "$it" "$seconds" semi "$out" "" \
                            "semi_${n}_${q}_w${w}_$it"
                    done
                done
            done
        done

        # Pin stiffness (only scenes with pins).
        if [ "$pinned" = 1 ]; then
            for s in $PIN_SCALES; do
                for it in $scene_iterations $CONVERGED; do
                    record pins full - 8 "$s" "$it" - full "$ref_bake" \
                        "\"full_pin_stiffness\": $s" "full_pin${s}_$it"
                done
            done
            for q in none all; do
                method=linear; [ "$q" = all ] && method=quadratic
                for n in $PIN_HANDLES; do
                    bake_one "$surface" "$n" "$q" 8 "$dir/bake_${n}_${q}_w8.h5" > /dev/null
                    for s in $PIN_SCALES; do
                        for it in $scene_iterations $CONVERGED; do
                            record pins "$method" "$n" 8 "$s" "$it" - semi "$dir/bake_${n}_${q}_w8.h5" \
                                "\"reduced_pin_stiffness\": $s" "semi_${n}_${q}_pin${s}_$it"
                        done
                        # The subspace's own error with the pins matched: against full-space
                        # PD converged with the same pin stiffness.
                        reference="$dir/full_pin${s}_$CONVERGED/trajectory.h5" \
                            record pins_matched "$method" "$n" 8 "$s" "$CONVERGED" - semi \
                            "$dir/bake_${n}_${q}_w8.h5" "\"reduced_pin_stiffness\": $s" \
                            "semi_${n}_${q}_pin${s}_matched"
                    done
                done
            done
        fi
    done
    mv "$csv.tmp" "$csv"
fi
[ -s "$csv" ] || { echo "error_limits: no $csv (run once without LIMITS_ONLY_TABLES)" >&2; exit 1; }

# The tables (RMS %; max % and the centre of mass's drop against the reference's, converged).
tables="$work/limits.md"
awk -F, -v its="$ITERATIONS $check" -v conv="$CONVERGED" -v fast="$scene_iterations" '
    NR == 1 { next }
    $2 == "reference" { refdrop[$1] = $12; next }
    { key = $1 SUBSEP $2 SUBSEP $3 SUBSEP $4 SUBSEP $5 SUBSEP $6 SUBSEP $7
      rms[key] = $10; mx[key] = $11; ms[key] = $9; bake[key] = $8; drop[key] = $12
      row = $1 SUBSEP $2 SUBSEP $3 SUBSEP $4 SUBSEP $5 SUBSEP $6
      if (!(row in seen)) { seen[row] = 1; order[$1, $2, ++count[$1, $2]] = $3 SUBSEP $4 SUBSEP $5 SUBSEP $6 }
      if (!($1 in has)) { has[$1] = 1; scenes[++ns] = $1 } }
    function cell(k) { return (k in rms) ? sprintf("%.3g", rms[k]) : "-" }
    function maxof(k) { return (k in mx) ? sprintf("%.3g", mx[k]) : "-" }
    function ratio(k, sc) { return (k in drop && refdrop[sc] > 0) ? sprintf("%.3f", drop[k] / refdrop[sc]) : "-" }
    function name(m) { return m == "full" ? "full-space" : m }
    # One row per setting of STUDY in every scene, with the columns named in COLUMNS.
    function table(study, columns,    n, c, h, s, r, sc, f, base, kf, kc, v) {
        n = split(columns, c, " ")
        h["scene"] = "scene"; h["method"] = "method"; h["handles"] = "handles"
        h["weights"] = "weights per node"; h["pin"] = "pin"; h["bake"] = "bake s"
        h["ms"] = "ms/step " fast " it"; h["rms_fast"] = "RMS " fast " it"
        h["rms_conv"] = "RMS " conv " it"; h["max_conv"] = "max " conv " it"
        h["drop_conv"] = "drop ratio " conv " it"
        h["matched"] = "RMS " conv " it against full-space, same pin"
        for (i = 1; i <= n; ++i) printf "| %s ", h[c[i]]
        printf "|\n"
        for (i = 1; i <= n; ++i) printf "| %s ", (i <= 2 ? "---" : "---:")
        printf "|\n"
        for (s = 1; s <= ns; ++s) {
            sc = scenes[s]
            for (r = 1; r <= count[sc, study]; ++r) {
                base = sc SUBSEP study SUBSEP order[sc, study, r]
                split(order[sc, study, r], f, SUBSEP)
                kf = base SUBSEP fast; kc = base SUBSEP conv
                v["scene"] = sc; v["method"] = name(f[1]); v["handles"] = f[2]; v["weights"] = f[3]
                v["pin"] = f[4]; v["bake"] = bake[kf]; v["ms"] = ms[kf]; v["rms_fast"] = cell(kf)
                v["rms_conv"] = cell(kc); v["max_conv"] = maxof(kc); v["drop_conv"] = ratio(kc, sc)
                v["matched"] = cell(sc SUBSEP study "_matched" SUBSEP order[sc, study, r] SUBSEP conv)
                for (i = 1; i <= n; ++i) printf "| %s ", v[c[i]]
                printf "|\n"
            }
        }
    }
    END {
        ni = split(its, it, " ")
        print "### Iterations against the subspace\n"
        print "RMS % of the bbox diagonal at each iteration count; max % and the drop ratio (the centre of mass'"'"'s"
        print "largest fall below its start, over the reference'"'"'s: above 1 sags more) at " fast " and " conv " iterations.\n"
        for (s = 1; s <= ns; ++s) {
            sc = scenes[s]
            printf "#### %s\n\n| method | handles |", sc
            for (i = 1; i <= ni; ++i) printf " RMS %s it |", it[i]
            printf " max %s it | drop ratio %s it | drop ratio %s it |\n| --- | ---: |", conv, fast, conv
            for (i = 1; i <= ni + 3; ++i) printf " ---: |"
            printf "\n"
            for (r = 1; r <= count[sc, "iterations"]; ++r) {
                base = sc SUBSEP "iterations" SUBSEP order[sc, "iterations", r]
                split(order[sc, "iterations", r], f, SUBSEP)
                printf "| %s | %s |", name(f[1]), f[2]
                for (i = 1; i <= ni; ++i) printf " %s |", cell(base SUBSEP it[i])
                k = base SUBSEP conv
                printf " %s | %s | %s |\n", maxof(k), ratio(base SUBSEP fast, sc), ratio(k, sc)
            }
            printf "\n"
        }
        print "### Weights kept per node\n"
        print "Bake seconds on one thread and ms per step from one run each (indicative, not a benchmark).\n"
        table("weights", "scene method handles weights bake ms rms_fast rms_conv max_conv")
        print "\n### Pin stiffness\n"
        print "Full-space rows: solver.full_pin_stiffness; reduced rows: solver.reduced_pin_stiffness (x the largest"
        print "diagonal entry of the system matrix). The reference pins at 1e8.\n"
        table("pins", "scene method handles pin rms_fast rms_conv max_conv drop_conv matched")
    }
' "$csv" > "$tables"
echo "error_limits: wrote $csv and $tables"
