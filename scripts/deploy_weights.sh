#!/usr/bin/env bash
# The lab's weights path in one command, after a diagnosis says the network should be retrained:
#   retrain (deltactl train) -> held-out Table 1 (deltactl table1) -> quantise (deltactl quantise:
#   the ROM .mem files and the board's identify.mem) -> bitstream with those ROMs (CMake target
#   `bitstream` in a build tree of its own, -DDELTA_NETWORK_WEIGHTS=W.json; timing checked) ->
#   flash (deltactl flash: writes the iCEBreaker's flash, waits for the board, checks its identify
#   against the bitstream's build id and the weights CRC) -> verify (deltactl host status).
# Without --flash it stops before touching the board and prints what flashing would do
# (deltactl flash --dry-run). Every step's output is in DIR; the first failing step stops it.
#
# Usage: scripts/deploy_weights.sh --data FIT.csv --out-dir DIR [--holdout CHECK.csv] [--seed N]
#                                  [--weights W.json] [--no-bitstream] [--flash] [--config FILE]
#   --data FIT.csv:      the recording to retrain on (deltactl train; a merged drag, docs/lab_loop.md).
#   --out-dir DIR:       where every step writes (W.json, the logs, mem/, the bitstream).
#   --holdout CHECK.csv: also print Table 1 on this held-out recording (deltactl table1).
#   --seed N:            the training seed (default 1).
#   --weights W.json:    skip training, deploy these weights (e.g. trained elsewhere).
#   --no-bitstream:      stop after quantising (the ROM files and identify.mem; no nextpnr run).
#   --flash:             flash the board and verify it (else: a dry run of the flash).
#   --config FILE:       the lab PC's configuration (default /etc/deltactl/deltactl.conf) for the
#                        port; the weights and bitstream it names are replaced by the new ones.
# Exit: 0 when every step passed; else the failing step's exit code (its log in DIR); 2: bad usage.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
# The usage: this file's leading comment block, without the '#'.
usage() { awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$0"; }
data="" holdout="" out="" seed=1 weights="" bitstream=1 flash=0 config=/etc/deltactl/deltactl.conf
while (($#)); do
  case "$1" in
    --data) data=$2; shift 2 ;;
    --holdout) holdout=$2; shift 2 ;;
    --out-dir) out=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --weights) weights=$2; shift 2 ;;
    --no-bitstream) bitstream=0; shift ;;
    --flash) flash=1; shift ;;
    --config) config=$2; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) echo "deploy_weights: unknown argument '$1'" >&2; usage >&2; exit 2 ;;
  esac
done
[[ -n $out ]] || { echo "deploy_weights: --out-dir DIR is required" >&2; exit 2; }
[[ -n $data || -n $weights ]] || { echo "deploy_weights: --data FIT.csv (or --weights W.json) is required" >&2; exit 2; }
((flash == 0 || bitstream == 1)) || { echo "deploy_weights: --flash needs the bitstream (drop --no-bitstream)" >&2; exit 2; }
deltactl=$root/build/bin/deltactl
[[ -x $deltactl ]] || bash "$root/scripts/build.sh" --target deltactl >&2
mkdir -p "$out"
out=$(cd "$out" && pwd)
step() { printf '\n== deploy_weights: %s\n' "$1"; }
started=$SECONDS

if [[ -z $weights ]]; then
  step "1. retrain the network on $data (seed $seed) -> $out/W.json"
  # The deployed model (train's default): the static network on backlash-free targets plus the
  # per-joint backlash compensation the board's interpolator applies (half_play.mem).
  "$deltactl" train --data "$data" --out "$out/W.json" --seed "$seed" 2>"$out/train.log"
  tail -2 "$out/train.log"
  weights=$out/W.json
else
  step "1. weights given: $weights (no training)"
  cp "$weights" "$out/W.json"
  weights=$out/W.json
fi
if [[ -n $holdout ]]; then
  step "2. held-out Table 1 ($holdout)"
  if grep -q '"model": "deployed"' "$weights"; then
    "$deltactl" table1 --data "${data:-$holdout}" --holdout "$holdout" --deployed "$weights"
  else
    "$deltactl" table1 --data "${data:-$holdout}" --holdout "$holdout" --network "$weights"
  fi
fi

step "3. quantise for the board's ROMs -> $out/mem"
mkdir -p "$out/mem"
"$deltactl" quantise --weights "$weights" --out-dir "$out/mem" >"$out/quantise.log"
tail -3 "$out/quantise.log"
[[ -s $out/mem/identify.mem ]] || { echo "deploy_weights: quantise wrote no identify.mem" >&2; exit 1; }
if ((bitstream == 0)); then
  step "done without a bitstream (--no-bitstream) in $((SECONDS - started)) s: $out/mem"
  exit 0
fi

step "4. bitstream with these weights (a build tree of its own: $out/build)"
if [[ ! -f $out/build/CMakeCache.txt ]]; then
  if command -v ccache >/dev/null; then export CMAKE_CXX_COMPILER_LAUNCHER=ccache; fi
  cmake -S "$root" -B "$out/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDELTA_NETWORK_WEIGHTS="$weights" >/dev/null
fi
cmake --build "$out/build" --target bitstream -j "$(nproc)" | tail -5
fpga=$out/build/rtl/board/fpga
cp "$fpga/icebreaker_top.bin" "$out/icebreaker_top.bin"
cp "$out/build/rtl/network/mem/identify.mem" "$out/identify.mem"
cat "$fpga/timing.txt"

# The configuration for flashing: the lab's, with these weights and this bitstream.
conf=$out/deltactl.conf
if [[ -r $config ]]; then
  sed -e "s#^weights = .*#weights = $weights#" -e "s#^bitstream = .*#bitstream = $out/icebreaker_top.bin#" "$config" >"$conf"
else
  printf '[board]\nport = /dev/delta-board\n[network]\nweights = %s\nbitstream = %s\n' "$weights" "$out/icebreaker_top.bin" >"$conf"
fi
if ((flash == 0)); then
  step "5. what flashing would do (run again with --flash)"
  "$deltactl" flash --config "$conf" --dry-run
  echo "done in $((SECONDS - started)) s; then point [network] weights of $config at $weights"
  exit 0
fi
step "5. flash and verify the board's identify"
"$deltactl" flash --config "$conf"
port=$(sed -n 's/^port = //p' "$conf")
step "6. the board as the host controller sees it"
"$deltactl" host status --port "$port"
echo "done in $((SECONDS - started)) s. Now set [network] weights = $weights in $config and restart deltactl.service"
