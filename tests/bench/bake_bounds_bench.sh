#!/usr/bin/env bash
# The bounds benchmark (docs/mat-bake.md, "Bounds"; not a test): `mat-bake check` on every .off
# surface of a folder, then a bake with --spheres N of every surface that check accepts, with a
# time limit. One row per surface (check time and verdict, bake time and result, what each
# bounded stage reached), then the check times (min/median/max) and each bound's largest reach.
# Usage: tests/bench/bake_bounds_bench.sh [BUILD_DIR] [MESH_DIR] [SPHERES] [TIME_LIMIT_S]
#   MESH_DIR defaults to the CGAL demo meshes (tar xzf /usr/share/doc/libcgal-dev/data.tar.gz
#   data/meshes into /work/cgal-data); SPHERES 100; TIME_LIMIT_S 300 per bake.
set -uo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${1:-$root/build}"
meshes="${2:-/work/cgal-data/data/meshes}"
spheres="${3:-100}"
limit="${4:-300}"
bake="$build/preprocess/mat-bake"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.3f", b - a }'; }

printf "mesh\tfaces\tcheck_s\tverdict\tpairs\tbake_s\tresult\tresamplings\tpieces\tqueries_per_sphere\tmesh3_vertices\n"
for surface in "$meshes"/*.off; do
    name="$(basename "$surface" .off)"
    start="$(now)"
    "$bake" --log-level warn check "$surface" > "$work/check.txt" 2>&1
    check_rc=$?
    check_s="$(since "$start")"
    faces="$(sed -n 's/.* vertices, \([0-9]*\) faces, .*/\1/p' "$work/check.txt" | head -1)"
    verdict="$(sed -n 's/^  verdict: //p' "$work/check.txt")"
    pairs="$(sed -n 's/^  intersecting face pairs: \([0-9]*\).*/\1/p' "$work/check.txt")"
    case "$verdict" in
        "not usable"*) kind=open ;;
        *"intersects itself") kind=self-intersecting ;;
        "closed"*) kind=closed ;;
        *) kind=unread ;;
    esac
    bake_s=-; result=-; resamplings=-; pieces=-; queries=-; vertices=-
    if [ "$check_rc" -eq 0 ]; then
        start="$(now)"
        timeout "$limit" "$bake" --log-level debug "$surface" --spheres "$spheres" \
            -o "$work/bake.h5" > "$work/bake.txt" 2>&1
        bake_rc=$?
        bake_s="$(since "$start")"
        case "$bake_rc" in
            0) result=OK ;;
            124) result="TIMEOUT" ;;
            *) result="FAIL: $(grep -m1 'error:' "$work/bake.txt" | cut -c1-160)" ;;
        esac
        resamplings="$(grep -c 'sampling 4x more densely' "$work/bake.txt")"
        pieces="$(sed -n 's/.* triangles in \([0-9]*\) pieces.*/\1/p' "$work/bake.txt" | tail -1)"
        queries="$(sed -n 's/.*surface queries (\([0-9.]*\) per initial sphere).*/\1/p' \
            "$work/bake.txt" | tail -1)"
        vertices="$(sed -n 's/.*Mesh_3 triangulation of \([0-9]*\) vertices.*/\1/p' \
            "$work/bake.txt" | tail -1)"
        rm -f "$work/bake.h5"
    fi
    printf "%s\t%s\t%.3f\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n" "$name" "${faces:--}" "$check_s" \
        "$kind" "${pairs:--}" "$bake_s" "$result" "$resamplings" "${pieces:--}" \
        "${queries:--}" "${vertices:--}"
done | tee "$work/rows.tsv"

echo
awk -F'\t' '$4 == "closed" || $4 == "self-intersecting" { print $3 }' "$work/rows.tsv" | sort -g \
    > "$work/check_times.txt"
awk '{ t[NR] = $1 } END {
        printf "check on the closed surfaces: min %.3f s, median %.3f s, max %.3f s\n", t[1],
            (NR % 2 ? t[(NR + 1) / 2] : (t[NR / 2] + t[NR / 2 + 1]) / 2), t[NR] }' \
    "$work/check_times.txt"
awk -F'\t' -v spheres="$spheres" '
    $4 == "closed" || $4 == "self-intersecting" { closed++ }
    $4 == "self-intersecting" { self++ }
    $6 != "-" { baked++; if ($7 == "OK") ok++; if ($6 > bake_max) bake_max = $6 }
    $8 != "-" && $8 > resample_max { resample_max = $8 }
    $9 != "-" && $9 > pieces_max { pieces_max = $9 }
    $10 != "-" && $10 > queries_max { queries_max = $10; queries_mesh = $1 }
    $11 != "-" && $11 > vertices_max { vertices_max = $11; vertices_mesh = $1 }
    END {
        printf "closed surfaces: %d (%d intersect themselves and are refused)\n", closed, self
        printf "bakes with --spheres %d: %d of %d OK, longest %.1f s\n", spheres, ok, baked, bake_max
        printf "medial resamplings: max %d (bound 2)\n", resample_max
        printf "inner Voronoi pieces: max %d (bound: the %d spheres asked)\n", pieces_max, spheres
        printf "simplification surface queries per initial sphere: max %.2f on %s " \
            "(bound --medial-query-bound)\n", queries_max, queries_mesh
        printf "Mesh_3 vertices: max %d on %s (bound --max-tet-vertices)\n", vertices_max,
            vertices_mesh
    }' "$work/rows.tsv"
