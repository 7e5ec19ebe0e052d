#!/usr/bin/env bash
# Every script with a --help prints its usage: exit 0, the script's own invocation, and only lines
# of its leading comment block (never a line of its code). Usage: script_help.sh SOURCE_DIR.
set -euo pipefail
source_dir=$(cd "$1" && pwd)
cd "$source_dir"
status=0 checked=0
for script in scripts/*.sh scripts/*/*.sh; do
  grep -q -- '-h|--help)' "$script" || continue
  checked=$((checked + 1))
  header=$(awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$script")
  if ! help=$(timeout 20 bash "$script" --help 2>&1); then
    echo "script help: $script --help exits non-zero" >&2
    status=1
    continue
  fi
  [[ $help == *"$script"* ]] || { echo "script help: $script --help does not show how to call it" >&2; status=1; }
  while IFS= read -r line; do
    if ! grep -qxF -- "$line" <<<"$header"; then
      echo "script help: $script --help prints a line that is not its usage: '$line'" >&2
      status=1
      break
    fi
  done <<<"$help"
done
((checked >= 5)) || { echo "script help: only $checked scripts with --help found" >&2; exit 1; }
((status == 0)) && echo "script help: $checked scripts print their usage"
exit $status
