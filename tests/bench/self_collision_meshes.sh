#!/usr/bin/env bash
# Self collision on real meshes (docs/method.md, section 5, "Self collision at rest" and "Self
# collision on real meshes"): each closed mesh of Debian's libcgal-demo data (or those named) is
# baked with 100 generated spheres, then run semi-reduced with self collision on:
#   rest: no gravity, no ground, 100 steps: the most contacts and the most energy in any frame
#         (a body at rest must stay at rest: both 0);
#   drop: its lowest point DROP_HEIGHT diagonals (default 0.5) above the ground, 100 steps, self
#         collision off and on:
#         the largest total energy over its start (never above 1), how far the free fall with
#         self collision on strays from the one without it (largest momentum difference relative
#         to the momentum, over the frames before either run touches anything), the largest
#         strain of each run, and the loop time of each (on / off: the cost of self collision);
#   recall: the drop with self collision on over 50 steps under --check-collisions: the recall
#         of intersecting triangle pairs between non-adjacent primitives (section 4).
#   tests/bench/self_collision_meshes.sh [BUILD_DIR] [THREADS] [MESH...]
#   SOLVER_EXTRA='"self_skin": 0' tests/bench/...   more keys for every scene's "solver" block
#   RUN_ARGS="--solver full" tests/bench/...         more mat-run arguments for every run
# Material: density 1000 kg/m^3, Poisson ratio 0.4, Young's modulus YOUNGS_PER_METRE (default 5e5)
# Pa times the diagonal in metres, so that the sag under gravity (rho g L / E, 0.02 by default) is
# the same at any size; dt = 1/30 s, 10 iterations.
# The bakes are kept in $SELF_BENCH_WORK (default BUILD_DIR/self_collision_meshes) for the next
# run; the meshes come from /usr/share/doc/libcgal-dev/data.tar.gz (package libcgal-dev).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
threads="${2:-2}"
shift $(($# < 2 ? $# : 2))
default_meshes=(cactus homer hand handle triceratops retinal spool blobby bear_bis fandisk
    knot1 knot2 rotor pinion femur eight joint elephant helmet anchor_dense couplingdown turbine
    cheese)
meshes=("${@:-${default_meshes[@]}}")
bake="$build/preprocess/mat-bake"
run="$build/runtime/mat-run"
for tool in "$bake" "$run"; do
    [ -x "$tool" ] || { echo "self_collision_meshes: no $tool (build first)" >&2; exit 1; }
done
work="${SELF_BENCH_WORK:-$build/self_collision_meshes}"
archive=/usr/share/doc/libcgal-dev/data.tar.gz
mkdir -p "$work"
work="$(cd "$work" && pwd)" # the scenes name their bakes by this path, not relative to themselves
if [ ! -d "$work/data/meshes" ]; then
    [ -f "$archive" ] || { echo "self_collision_meshes: no $archive (apt-get install libcgal-dev)" >&2; exit 1; }
    tar -xzf "$archive" -C "$work" data/meshes
fi

# The bounding box of an OFF surface (OFF, COFF, NOFF...: the first three numbers of each vertex
# line): "xmin ymin zmin xmax ymax zmax".
off_box() {
    awk '{ sub(/#.*/, "") } NF == 0 { next }
        state == 0 { state = 1; if ($1 ~ /OFF$/) { if (NF == 1) next; $1 = "" } }
        state == 1 { nv = $1; state = 2; next }
        state == 2 && v < nv {
            for (a = 1; a <= 3; ++a) {
                x = $a + 0
                if (v == 0 || x < lo[a]) lo[a] = x
                if (v == 0 || x > hi[a]) hi[a] = x
            }
            ++v
        }
        END { printf "%.9g %.9g %.9g %.9g %.9g %.9g\n", lo[1], lo[2], lo[3], hi[1], hi[2], hi[3] }' "$1"
}

# scene FILE BAKE GRAVITY_Y POSITION_Y SELF GROUND YOUNGS_MODULUS
scene() {
    local ground=""
    [ "$6" = on ] && ground=', "colliders": [{ "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.6 }]'
    cat > "$1" <<EOF
{
  "time": { "dt": 0.0333333333, "frames": 20, "iterations": 10 },
  "gravity": [0, $3, 0],
  "solver": { "collision": "bounded", "self_collision": "$5"${SOLVER_EXTRA:+, $SOLVER_EXTRA} },
  "objects": [
    { "name": "body", "bake": "$2", "position": [0, $4, 0],
      "material": { "youngs_modulus": $7, "poisson_ratio": 0.4, "density": 1000 } }
  ]$ground,
  "output": { "format": "h5", "every": 5 }
}
EOF
}

# Per frame of a --stats frames file: contacts, total energy, max strain, momentum (as printed),
# and whether the body had any contact candidate.
frame_rows() {
    awk '{
        c = 0; if (match($0, /"contacts":[0-9]+/)) c = substr($0, RSTART + 11, RLENGTH - 11)
        e = 0; if (match($0, /"total":[-0-9.e+]+/)) e = substr($0, RSTART + 8, RLENGTH - 8)
        s = 0; if (match($0, /"max_strain":[-0-9.e+]+/)) s = substr($0, RSTART + 13, RLENGTH - 13)
        p = ""; if (match($0, /"momentum":\[[^]]*\]/)) p = substr($0, RSTART + 12, RLENGTH - 13)
        touched = index($0, "\"contact\":{") > 0
        print c, e, s, p, touched
    }' "$1"
}

loop_seconds() { awk '/^simulated/ { for (i = 1; i <= NF; ++i) if ($i == "in" && $(i + 2) == "s,") v = $(i + 1) } END { print v }' "$1"; }

printf "%-14s %7s %8s %10s %8s %10s %7s %7s %8s %8s %6s %9s %9s\n" mesh tets rest_max rest_energy \
    drop_E fall_dev strain0 strain1 loop_off loop_on on/off far_recall self_pen
for mesh in "${meshes[@]}"; do
    surface="$work/data/meshes/$mesh.off"
    [ -f "$surface" ] || { echo "self_collision_meshes: no $surface" >&2; exit 1; }
    h5="$work/$mesh.h5"
    if [ ! -f "$h5" ]; then
        "$bake" "$surface" --spheres 100 --threads "$threads" -o "$h5" > "$work/$mesh.bake.log" 2>&1 \
            || { echo "$mesh: bake failed: $(tail -1 "$work/$mesh.bake.log")"; continue; }
    fi
    read -r x0 y0 z0 x1 y1 z1 < <(off_box "$surface")
    diagonal=$(awk -v a="$x0" -v b="$y0" -v c="$z0" -v d="$x1" -v e="$y1" -v f="$z1" \
        'BEGIN { printf "%.9g", sqrt((d - a)^2 + (e - b)^2 + (f - c)^2) }')
    height=$(awk -v y="$y0" -v d="$diagonal" -v k="${DROP_HEIGHT:-0.5}" 'BEGIN { printf "%.9g", k * d - y }')
    youngs=$(awk -v d="$diagonal" -v e="${YOUNGS_PER_METRE:-5e5}" 'BEGIN { printf "%.6g", e * d }')
    dir="$work/$mesh.runs"
    mkdir -p "$dir"
    scene "$dir/rest.json" "$h5" 0 0 on off "$youngs"
    scene "$dir/drop_off.json" "$h5" -9.81 "$height" off on "$youngs"
    scene "$dir/drop_on.json" "$h5" -9.81 "$height" on on "$youngs"
    "$run" "$dir/rest.json" --threads "$threads" ${RUN_ARGS:-} --stats "$dir/rest.stats.json" -o "$dir/rest" > "$dir/rest.log" 2>&1
    "$run" "$dir/drop_off.json" --threads "$threads" ${RUN_ARGS:-} --stats "$dir/off.stats.json" -o "$dir/off" > "$dir/off.log" 2>&1
    "$run" "$dir/drop_on.json" --threads "$threads" ${RUN_ARGS:-} --stats "$dir/on.stats.json" -o "$dir/on" > "$dir/on.log" 2>&1
    "$run" "$dir/drop_on.json" --threads "$threads" ${RUN_ARGS:-} --frames 10 --check-collisions -o "$dir/check" > "$dir/check.log" 2>&1
    tets=$(awk '/nodes,.*tets/ { for (i = 1; i <= NF; ++i) if ($i ~ /^tets/) print $(i - 1) }' "$dir/rest.log" | head -1)
    read -r rest_max rest_energy < <(frame_rows "$dir/rest.stats.frames.jsonl" \
        | awk '{ if ($1 > c) c = $1; if ($2 > e) e = $2 } END { print c + 0, e + 0 }')
    frame_rows "$dir/off.stats.frames.jsonl" > "$dir/off.rows"
    frame_rows "$dir/on.stats.frames.jsonl" > "$dir/on.rows"
    read -r drop_energy fall_dev strain0 strain1 < <(paste -d' ' "$dir/off.rows" "$dir/on.rows" | awk '
        NR == 1 { start = $7 }
        {
            if ($7 > most) most = $7
            if ($3 > s0) s0 = $3
            if ($8 > s1) s1 = $8
            if ($5 || $10) touched = 1
            if (!touched) {
                split($4, p, ","); split($9, q, ",")
                n = sqrt(p[1]^2 + p[2]^2 + p[3]^2)
                d = sqrt((p[1] - q[1])^2 + (p[2] - q[2])^2 + (p[3] - q[3])^2)
                if (n > 0 && d / n > dev) dev = d / n
            }
        }
        END { printf "%.6f %.2g %.3f %.3f\n", most / start, dev, s0, s1 }')
    off_s=$(loop_seconds "$dir/off.log")
    on_s=$(loop_seconds "$dir/on.log")
    recall=$(awk '/^collision check/ { print $7 }' "$dir/check.log")
    self_pen=$(awk '/^collision check/ { for (i = 1; i < NF; ++i) if ($i == "self" && $(i + 1) == "penetration") print $(i + 2) }' "$dir/check.log")
    printf "%-14s %7s %8s %10.3g %8s %10s %7s %7s %8s %8s %6.2f %9s %9s\n" "$mesh" "$tets" "$rest_max" \
        "$rest_energy" "$drop_energy" "$fall_dev" "$strain0" "$strain1" "$off_s" "$on_s" \
        "$(awk -v a="$on_s" -v b="$off_s" 'BEGIN { print a / b }')" "$recall" "$self_pen"
done
