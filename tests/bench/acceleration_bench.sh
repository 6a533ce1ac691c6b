#!/usr/bin/env bash
# acceleration_bench.sh [BUILD_DIR]
# Plain PD against Anderson-accelerated PD (docs/method.md, "Accelerated iterations"), in every
# solver mode, on the chart scenes docs/charts/cantilever.json and twisting_limb.json: bakes the
# scenes' surfaces (tet size TET_SIZE, HANDLES handle counts, linear and quadratic), runs the
# reference (full-space PD at REF_ITERATIONS, plain) and a check of it (at CHECK_ITERATIONS), then
# each mode plain at PLAIN_ITERATIONS and accelerated at ANDERSON_ITERATIONS, each with
# `mat-run --stats --reference`. Accuracy: the RMS surface distance to the reference (% of the
# bounding-box diagonal, the largest over the frames), and, for the reduced modes, the same
# distance to the mode's own converged solution (plain, REF_ITERATIONS iterations, same bake):
# their error against full space mixes the subspace's error with the iteration's, the second is
# the iteration's alone. Time: ms per step of the solver phases
# (local + rhs + solve + reconstruct + contact + acceleration), the median of REPEATS runs, plain
# and accelerated alternated, THREADS threads. Prints a markdown table (also WORK/table.md) and
# WORK/results.csv; the target columns say whether Anderson at TARGET_ITERATIONS reaches plain's
# error at TARGET_PLAIN iterations, against either reference.
#   tests/bench/acceleration_bench.sh                       tools from build/
#   BENCH_WORK=/tmp/acc tests/bench/acceleration_bench.sh   work directory (default BUILD/acceleration)
# Environment overrides: MAT_BAKE, MAT_RUN, SCENES, MODES, TET_SIZE, REF_ITERATIONS,
# CHECK_ITERATIONS, PLAIN_ITERATIONS, ANDERSON_ITERATIONS, TARGET_PLAIN, TARGET_ITERATIONS,
# REPEATS (default 3), THREADS (default 1), WINDOW (anderson_window, default 5).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
bake="${MAT_BAKE:-$build/preprocess/mat-bake}"
run="${MAT_RUN:-$build/runtime/mat-run}"
work="${BENCH_WORK:-$build/acceleration}"
for tool in "$bake" "$run"; do
    [ -x "$tool" ] || { echo "acceleration_bench: no $tool (build it, or pass the build directory)" >&2; exit 1; }
done
SCENES="${SCENES:-cantilever:samples/rounded_bar/rounded_bar.obj twisting_limb:samples/capsule/capsule.obj}"
# SOLVER:HANDLES:QUADRATIC; full space runs on the first bake's tets.
MODES="${MODES:-full semi:8:none semi:8:all semi:24:none semi:24:all hyper:8:none hyper:24:all}"
TET_SIZE="${TET_SIZE:-0.04}"
REF_ITERATIONS="${REF_ITERATIONS:-400}"
CHECK_ITERATIONS="${CHECK_ITERATIONS:-800}"
PLAIN_ITERATIONS="${PLAIN_ITERATIONS:-5 10 15 20 50}"
ANDERSON_ITERATIONS="${ANDERSON_ITERATIONS:-5 10 15 20}"
TARGET_PLAIN="${TARGET_PLAIN:-50}"
TARGET_ITERATIONS="${TARGET_ITERATIONS:-15}"
REPEATS="${REPEATS:-3}"
THREADS="${THREADS:-1}"
WINDOW="${WINDOW:-5}"

# scene_copy SCENE_JSON BAKE ITERATIONS ACCELERATION OUT (self collision off, as in
# docs/make_charts.sh: the chart scenes' bodies never reach themselves)
scene_copy() {
    sed -e "s|\"bake\": *\"[^\"]*\"|\"bake\": \"$2\"|" \
        -e "s|\"iterations\": *[0-9]*|\"iterations\": $3|" \
        -e "s|\"output\":|\"solver\": { \"acceleration\": \"$4\", \"anderson_window\": $WINDOW, \"self_collision\": \"off\" }, \"output\":|" \
        "$1" > "$5"
    grep -q "\"acceleration\": \"$4\"" "$5" || { echo "acceleration_bench: could not edit $5" >&2; exit 1; }
}
# "ms rms" from a --stats file.
read_stats() {
    python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
ms = sum(d["ms_per_step"].get(k, 0.0) for k in ("local", "rhs", "solve", "reconstruct", "contact", "acceleration"))
print(f"{ms:.6g} {d['reference_error']['rms_percent']:.6g}")
PY
}
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

mkdir -p "$work"
csv="$work/results.csv"
echo "scene,mode,acceleration,iterations,ms_per_step,rms_percent,rms_own_percent" > "$csv.tmp"
for entry in $SCENES; do
    scene="${entry%%:*}"; surface="$root/${entry#*:}"
    json="$root/docs/charts/$scene.json"
    dir="$work/$scene"
    mkdir -p "$dir"
    first=""
    for mode in $MODES; do
        [ "$mode" = full ] && continue
        n="$(echo "$mode" | cut -d: -f2)"; q="$(echo "$mode" | cut -d: -f3)"
        out="$dir/bake_${n}_$q.h5"
        if [ ! -s "$out" ] || [ "$out" -ot "$surface" ]; then
            "$bake" "$surface" --spheres "$n" --samples 5000 --tet-size "$TET_SIZE" --quadratic "$q" \
                -o "$out" --log-level warn --threads "$THREADS" > "$dir/bake_${n}_$q.log" 2>&1
        fi
        [ -n "$first" ] || first="$out"
    done
    [ -n "$first" ] || { echo "acceleration_bench: MODES needs a reduced mode (its bake gives the tets)" >&2; exit 1; }
    # The reference and its check: plain full-space PD at REF_ITERATIONS and CHECK_ITERATIONS.
    for it in "$REF_ITERATIONS" "$CHECK_ITERATIONS"; do
        scene_copy "$json" "$first" "$it" none "$dir/reference_$it.json"
        if [ ! -s "$dir/reference_$it/trajectory.h5" ] || [ "$dir/reference_$it/trajectory.h5" -ot "$run" ]; then
            "$run" "$dir/reference_$it.json" -o "$dir/reference_$it" --solver full \
                --threads "$THREADS" --log-level warn > "$dir/reference_$it.log"
        fi
    done
    reference="$dir/reference_$REF_ITERATIONS/trajectory.h5"
    "$run" "$dir/reference_$CHECK_ITERATIONS.json" -o "$dir/check" --solver full --threads "$THREADS" \
        --log-level warn --reference "$reference" --stats "$dir/check.stats.json" > /dev/null
    set -- $(read_stats "$dir/check.stats.json")
    echo "$scene,reference check,none,$CHECK_ITERATIONS,$1,$2,$2" >> "$csv.tmp"
    echo "acceleration_bench: $scene: full-space $CHECK_ITERATIONS against $REF_ITERATIONS iterations: RMS $2%"

    for mode in $MODES; do
        solver="${mode%%:*}"
        if [ "$mode" = full ]; then bakefile="$first"; else
            bakefile="$dir/bake_$(echo "$mode" | cut -d: -f2)_$(echo "$mode" | cut -d: -f3).h5"; fi
        # The mode's own converged solution (full space: the reference itself).
        own="$reference"
        if [ "$mode" != full ]; then
            name="${mode//:/_}_own_$REF_ITERATIONS"
            scene_copy "$json" "$bakefile" "$REF_ITERATIONS" none "$dir/$name.json"
            if [ ! -s "$dir/$name/trajectory.h5" ] || [ "$dir/$name/trajectory.h5" -ot "$run" ]; then
                "$run" "$dir/$name.json" -o "$dir/$name" --solver "$solver" --threads "$THREADS" \
                    --log-level warn > /dev/null
            fi
            own="$dir/$name/trajectory.h5"
        fi
        runs=""
        for it in $PLAIN_ITERATIONS; do runs="$runs none:$it"; done
        for it in $ANDERSON_ITERATIONS; do runs="$runs anderson:$it"; done
        declare -A times=() errors=() own_errors=()
        for repeat in $(seq "$REPEATS"); do
            # Alternate: plain and accelerated runs interleaved, in a rotating order per repeat.
            for r in $runs; do
                acc="${r%%:*}"; it="${r#*:}"
                name="${mode//:/_}_${acc}_$it"
                scene_copy "$json" "$bakefile" "$it" "$acc" "$dir/$name.json"
                "$run" "$dir/$name.json" -o "$dir/$name" --solver "$solver" --threads "$THREADS" \
                    --log-level warn --reference "$reference" --stats "$dir/$name.stats.json" > /dev/null
                set -- $(read_stats "$dir/$name.stats.json")
                times[$r]="${times[$r]:-} $1"
                errors[$r]="$2"
            done
        done
        for r in $runs; do
            acc="${r%%:*}"; it="${r#*:}"
            name="${mode//:/_}_${acc}_$it"
            own_errors[$r]="${errors[$r]}"
            if [ "$own" != "$reference" ]; then
                "$run" "$dir/$name.json" -o "$dir/$name" --solver "$solver" --threads "$THREADS" \
                    --log-level warn --reference "$own" --stats "$dir/$name.own.stats.json" > /dev/null
                set -- $(read_stats "$dir/$name.own.stats.json")
                own_errors[$r]="$2"
            fi
        done
        for r in $runs; do
            acc="${r%%:*}"; it="${r#*:}"
            ms="$(echo "${times[$r]}" | median)"
            echo "$scene,$mode,$acc,$it,$ms,${errors[$r]},${own_errors[$r]}" >> "$csv.tmp"
            printf 'acceleration_bench: %-14s %-13s %-9s %4s it  %9.3f ms/step  RMS %9.5f%%  own %9.5f%%\n' \
                "$scene" "$mode" "$acc" "$it" "$ms" "${errors[$r]}" "${own_errors[$r]}"
        done
        unset times errors own_errors
    done
done
mv "$csv.tmp" "$csv"

# The tables: per scene and mode, RMS error (%) at each iteration count against the full-space
# reference, then against the mode's own converged solution; ms per step; the target.
python3 - "$csv" "$work/table.md" "$PLAIN_ITERATIONS" "$ANDERSON_ITERATIONS" "$TARGET_PLAIN" \
    "$TARGET_ITERATIONS" "$THREADS" "$REF_ITERATIONS" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
plain_its, aa_its = sys.argv[3].split(), sys.argv[4].split()
target_plain, target_it, threads, ref_it = sys.argv[5], sys.argv[6], sys.argv[7], sys.argv[8]
out = []
for r in rows:
    if r["mode"] == "reference check":
        out.append(f"Reference check, {r['scene']}: full-space PD at {r['iterations']} iterations is "
                   f"{float(r['rms_percent']):.2g}% RMS from the reference ({ref_it} iterations).")
keys = []
for r in rows:
    k = (r["scene"], r["mode"])
    if r["mode"] != "reference check" and k not in keys:
        keys.append(k)
def get(k, acc, it, field):
    for r in rows:
        if (r["scene"], r["mode"], r["acceleration"], r["iterations"]) == (*k, acc, it):
            return float(r[field])
    return None
fmt = lambda v: "-" if v is None else f"{v:.3g}"
for field, title in (("rms_percent", f"against the full-space reference ({ref_it} iterations)"),
                     ("rms_own_percent", f"against the mode's own converged solution ({ref_it} plain iterations)")):
    out += ["", f"RMS error, % of the bounding-box diagonal, {title}:", ""]
    head = ["scene", "mode"] + [f"plain {i}" for i in plain_its] + [f"AA {i}" for i in aa_its]
    head.append(f"AA {target_it} <= plain {target_plain}")
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + " --- |" * len(head))
    for k in keys:
        cells = [k[0], k[1]]
        cells += [fmt(get(k, "none", i, field)) for i in plain_its]
        cells += [fmt(get(k, "anderson", i, field)) for i in aa_its]
        a, p = get(k, "anderson", target_it, field), get(k, "none", target_plain, field)
        cells.append("-" if a is None or p is None else ("yes" if a <= p else "no"))
        out.append("| " + " | ".join(cells) + " |")
out += ["", f"ms per step (solver phases, median of the repeats, {threads} thread(s)):", ""]
head = ["scene", "mode"] + [f"plain {i}" for i in plain_its] + [f"AA {i}" for i in aa_its]
out.append("| " + " | ".join(head) + " |")
out.append("|" + " --- |" * len(head))
for k in keys:
    cells = [k[0], k[1]] + [fmt(get(k, "none", i, "ms_per_step")) for i in plain_its]
    cells += [fmt(get(k, "anderson", i, "ms_per_step")) for i in aa_its]
    out.append("| " + " | ".join(cells) + " |")
out.append("")
out.append("Modes: full; SOLVER:HANDLES:QUADRATIC (none: linear handles, all: quadratic). Error: "
           "the RMS surface distance, the largest over the frames (`mat-run --reference`).")
open(sys.argv[2], "w").write("\n".join(out) + "\n")
print("\n".join(out))
PY
