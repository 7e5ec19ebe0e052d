#!/usr/bin/env bash
# The main job on built-in defaults (the simulated paper-like robot, the shipped weights): the
# paper's validation experiment and the math model's error, the network against it on held-out
# data, the same network in fixed point, HLS C++ and RTL (identical raw codes), the joint
# controllers in closed loop, the sim-to-real diagnosis, and the whole robot co-simulated around
# the board RTL (one period of experiment 1 with the deployed model the board ships; the plain
# network beside it) and around the C++ model board, bit-exact with it (75 s of the validation
# trajectory). Outputs go to build/run/.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/build.sh --target deltactl
out=build/run
mkdir -p "$out"
deltactl=build/bin/deltactl
effects=sim/paper_like_effects.json
weights=weights/paper_like.json

section() { printf '\n== %s\n\n' "$1"; }

section "1. Validation experiment on the paper-like virtual robot ($effects)"
$deltactl simulate --experiment validation --effects "$effects" --seed 1 --out "$out/fit.csv"
$deltactl simulate --experiment sweep --effects "$effects" --seed 7 --out "$out/check.csv"
$deltactl compare --data "$out/fit.csv" --plot "$out/validation_errors.png"

section "2. Table 1 on a held-out sweep: math model, shipped network ($weights), hybrid, deployed model"
$deltactl table1 --data "$out/fit.csv" --holdout "$out/check.csv" \
  --network "$weights" --hybrid weights/paper_like_hybrid.json --deployed weights/paper_like_deployed.json

section "3. The network (and the deployed model, rows in time order) in fixed point (golden model), HLS C++ and RTL"
raw_columns() { cut -d, -f4-6 "$1"; }
for model in "$weights" weights/paper_like_deployed.json; do
  name=$(basename "$model" .json)
  for backend in float fixed hls rtl; do
    $deltactl ik --weights "$model" --backend "$backend" --in "$out/check.csv" --out "$out/ik_${name}_$backend.csv"
  done
  if cmp -s <(raw_columns "$out/ik_${name}_fixed.csv") <(raw_columns "$out/ik_${name}_hls.csv") &&
     cmp -s <(raw_columns "$out/ik_${name}_fixed.csv") <(raw_columns "$out/ik_${name}_rtl.csv"); then
    echo "$name: fixed, hls and rtl: identical raw codes on all $(($(wc -l < "$out/ik_${name}_fixed.csv") - 1)) poses"
  else
    echo "MISMATCH: raw codes differ between back ends (see $out/ik_${name}_*.csv)" >&2
    exit 1
  fi
done

section "4. Joint controllers in closed loop (double vs fixed point, single-joint plant)"
$deltactl joint-loop --plot "$out/joint_loop.png"

section "5. Sim-to-real diagnosis of the paper-like robot (fit on the validation run, judged on the sweep)"
$deltactl diagnose --data "$out/fit.csv" --holdout "$out/check.csv" --json "$out/diagnosis.json" \
  --predictions "$out/diagnosis_predictions.csv" --report "$out/diagnosis/report.md"

section "6. Co-simulation: the board RTL (network + joint controllers) driving the paper-like robot"
# One period of experiment 1 after a 0.3 s start; about 4 s of wall time per simulated second.
# The board's shipped model: the deployed one (network + backlash compensation in the interpolator).
$deltactl cosim --weights weights/paper_like_deployed.json --effects "$effects" --trajectory experiment1 \
  --duration 5.3 --out "$out/cosim.csv" --plot "$out/cosim.png"
echo
echo "The same with the plain network ($weights) on the model board (bit-exact with the RTL board):"
$deltactl cosim --fidelity model --weights "$weights" --effects "$effects" --trajectory experiment1 --duration 5.3 \
  --out "$out/cosim_plain.csv"

section "7. Co-simulation on the model board: 75 s of the validation trajectory in closed loop"
# The C++ model board (bit-exact with the board RTL: ctest -R ModelBoard) runs free, about 45 x
# real time on this machine (scripts/bench_boards.sh): a few seconds of wall time. The first 75 s
# of the validation trajectory's 1333 s (x, y sinusoids of 5 mm, z descending).
$deltactl cosim --fidelity model --weights "$weights" --effects "$effects" --trajectory validation --duration 75 \
  --out "$out/cosim_model_validation.csv" --plot "$out/cosim_model_validation.png"
echo
echo "Outputs (recordings, plots, reports) in $out/"
