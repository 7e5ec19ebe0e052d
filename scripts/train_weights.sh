#!/usr/bin/env bash
# Regenerates the shipped weights (weights/paper_like.json, paper_like_hybrid.json, paper_like_deployed.json,
# paper_like_calibration_deployed.json) bit for bit:
# records the paper's validation trajectory (and the calibration trajectory) on the paper-like virtual
# robot and trains on it, seed 1.
# BUILD selects the build folder (default build/, configured by scripts/build.sh).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$root" && mkdir -p "${BUILD:-build}" && cd "${BUILD:-build}" && pwd)
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  bash "$root/scripts/build.sh" --target deltactl
else
  cmake --build "$build" -j2 --target deltactl
fi
deltactl="$build/bin/deltactl"
# Train from inside the data folder so the provenance names the recording without a machine path.
data="$build/weights-data"
mkdir -p "$data"
cd "$data"
"$deltactl" simulate --experiment validation --effects "$root/sim/paper_like_effects.json" --seed 1 \
  --out paper_like_validation_seed1.csv
"$deltactl" train --model network --data paper_like_validation_seed1.csv --seed 1 --out "$root/weights/paper_like.json"
"$deltactl" train --model hybrid --data paper_like_validation_seed1.csv --seed 1 \
  --out "$root/weights/paper_like_hybrid.json"
# The board's default model (the netlist, the bitstream, the package and virtual-board carry it):
# no joint ripple table, so that what the board runs needs no host shaping; the paper-like robot's
# 7.5 deg ripple on this 10 mm cube is within what its network follows (docs/lab_loop.md, section 4).
"$deltactl" train --model deployed --data paper_like_validation_seed1.csv --seed 1 --ripple-table off \
  --out "$root/weights/paper_like_deployed.json"
# The deployed model of the lab loop (docs/lab_loop.md): trained on the wider calibration trajectory,
# which turns each joint through several of the robot's ripples: it carries a joint ripple table.
"$deltactl" simulate --experiment calibration --effects "$root/sim/paper_like_effects.json" --seed 1 \
  --out paper_like_calibration_seed1.csv
"$deltactl" train --model deployed --data paper_like_calibration_seed1.csv --seed 1 \
  --out "$root/weights/paper_like_calibration_deployed.json"
echo "train_weights: wrote weights/paper_like.json, paper_like_hybrid.json, paper_like_deployed.json and" \
  "paper_like_calibration_deployed.json" \
  "(git diff shows any change)"
