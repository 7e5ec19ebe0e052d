#!/usr/bin/env bash
# The lab's model path in one command, after a diagnosis says the network should be retrained:
#   retrain (deltactl train) -> held-out Table 1 (deltactl table1) -> quantise (deltactl quantise:
#   the network in the board's formats, the model's CRC-32) -> load it onto the board (deltactl host
#   load: over the link, the drives off, in seconds; the gateware is the same for every model, so
#   there is no bitstream to build and nothing to flash) -> verify (deltactl host status).
# Without --port it stops before touching the board and prints the load command. Every step's
# output is in DIR; the first failing step stops it.
#
# Usage: scripts/deploy_weights.sh --data FIT.csv --out-dir DIR [--holdout CHECK.csv] [--seed N]
#                                  [--weights W.json] [--port PORT]
#   --data FIT.csv:      the recording to retrain on (deltactl train; a merged drag, docs/lab_loop.md).
#   --out-dir DIR:       where every step writes (W.json, the logs, mem/).
#   --holdout CHECK.csv: also print Table 1 on this held-out recording (deltactl table1).
#   --seed N:            the training seed (default 1).
#   --weights W.json:    skip training, deploy these weights (e.g. trained elsewhere).
#   --port PORT:         load the model onto the board there (deltactl host load; the service, which
#                        holds the port, stopped first) and show its status.
# Exit: 0 when every step passed; else the failing step's exit code (its log in DIR); 2: bad usage.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
# The usage: this file's leading comment block, without the '#'.
usage() { awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$0"; }
data="" holdout="" out="" seed=1 weights="" port=""
while (($#)); do
  case "$1" in
    --data) data=$2; shift 2 ;;
    --holdout) holdout=$2; shift 2 ;;
    --out-dir) out=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --weights) weights=$2; shift 2 ;;
    --port) port=$2; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) echo "deploy_weights: unknown argument '$1'" >&2; usage >&2; exit 2 ;;
  esac
done
[[ -n $out ]] || { echo "deploy_weights: --out-dir DIR is required" >&2; exit 2; }
[[ -n $data || -n $weights ]] || { echo "deploy_weights: --data FIT.csv (or --weights W.json) is required" >&2; exit 2; }
deltactl=${DELTACTL:-$root/build/bin/deltactl}
[[ -x $deltactl ]] || bash "$root/scripts/build.sh" --target deltactl >&2
mkdir -p "$out"
out=$(cd "$out" && pwd)
step() { printf '\n== deploy_weights: %s\n' "$1"; }
started=$SECONDS

if [[ -z $weights ]]; then
  step "1. retrain the network on $data (seed $seed) -> $out/W.json"
  # The deployed model (train's default): the static network on backlash-free targets plus the
  # per-joint backlash compensation the board's interpolator applies.
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

step "3. quantise: the board's formats and the model's CRC -> $out/mem"
mkdir -p "$out/mem"
"$deltactl" quantise --weights "$weights" --out-dir "$out/mem" >"$out/quantise.log"
tail -3 "$out/quantise.log"
if [[ -z $port ]]; then
  step "done in $((SECONDS - started)) s; load it (the drives off, the service stopped, or restarted with it configured):"
  echo "deltactl host load --port PORT --weights $weights"
  exit 0
fi
step "4. load the model onto the board on $port"
"$deltactl" host load --port "$port" --weights "$weights"
step "5. the board as the host controller sees it"
"$deltactl" host status --port "$port"
echo "done in $((SECONDS - started)) s. For the service: set [network] weights = $weights in its configuration" \
  "and restart deltactl.service (it loads its configured model when it connects)"
