#!/usr/bin/env bash
# Runs every command of docs/lab_loop.md between the lab-loop-test markers, as written, in a
# scratch folder that sees the repository's sim/ and weights/ (so the doc's relative paths hold),
# with deltactl's folder first on PATH. Usage: lab_loop_doc.sh SOURCE_DIR DELTACTL SCRATCH
set -euo pipefail
source_dir=$1 deltactl=$2 scratch=$3
rm -rf "$scratch" && mkdir -p "$scratch"
ln -s "$source_dir/sim" "$scratch/sim"
ln -s "$source_dir/weights" "$scratch/weights"
# The fenced sh blocks inside the markers, in order.
awk '/<!-- lab-loop-test: begin -->/{on=1; next} /<!-- lab-loop-test: end -->/{on=0}
     on && /^```sh/{code=1; next} on && /^```/{code=0; next} on && code' \
  "$source_dir/docs/lab_loop.md" > "$scratch/lab_loop.sh"
commands=$(grep -c '^deltactl' "$scratch/lab_loop.sh")
echo "lab_loop_doc: $commands deltactl commands from docs/lab_loop.md"
[[ $commands -ge 10 ]] || { echo "FAIL: too few commands found"; exit 1; }
cd "$scratch"
export PATH="$(dirname "$deltactl"):$PATH"
set -x
source ./lab_loop.sh
set +x
# The loop's outputs: the merged drag, the diagnosis, the trained weights, the closed-loop run's report.
for file in lab/drag.csv lab/sweep.csv lab/diagnosis.json lab/W.json lab/deploy/identify.mem lab/run_report.json; do
  [[ -s $file ]] || { echo "FAIL: $file missing"; exit 1; }
done
echo PASS
