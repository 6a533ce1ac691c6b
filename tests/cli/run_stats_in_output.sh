#!/usr/bin/env bash
# run_stats_in_output.sh MAT_RUN BAKE WORK_DIR
# --stats may name a file inside the -o directory, which the run itself creates: one frame of
# a one-object scene on BAKE with -o WORK_DIR/out --stats WORK_DIR/out/stats.json must write it.
set -euo pipefail
run="$1"; bake="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"
cp "$bake" "$work/body.h5"
cat > "$work/scene.json" <<'SCENE'
{
  "time": { "dt": 0.01, "frames": 1, "iterations": 2 },
  "objects": [{ "name": "body", "bake": "body.h5" }],
  "output": { "format": "obj", "every": 1 }
}
SCENE
"$run" "$work/scene.json" -o "$work/out" --stats "$work/out/stats.json" --threads 2
grep -q '"frames"' "$work/out/stats.json" || { echo "FAIL: no stats in $work/out/stats.json"; exit 1; }
