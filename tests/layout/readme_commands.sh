#!/usr/bin/env bash
# Every command block of the root README runs as written: each ```sh block (but the first, the two
# commands that build and test everything, which CI itself runs) is run by bash -euo pipefail in a
# scratch folder that holds the README's relative paths (build/, weights/, sim/) as links into this
# checkout and its build. Usage: readme_commands.sh SOURCE_DIR BUILD_DIR. Exit 1 naming the block.
set -euo pipefail
source_dir=$(cd "$1" && pwd)
build_dir=$(cd "$2" && pwd)
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
ln -s "$build_dir" "$scratch/build"
for folder in weights sim scripts; do ln -s "$source_dir/$folder" "$scratch/$folder"; done
# The blocks, one file each (awk: lines between ```sh and ```).
awk -v dir="$scratch" '
  /^```sh$/ { block++; inside = 1; file = sprintf("%s/block%02d.sh", dir, block); next }
  /^```$/ { inside = 0; next }
  inside { print > file }
' "$source_dir/README.md"
blocks=("$scratch"/block*.sh)
((${#blocks[@]} >= 2)) || { echo "readme: fewer than two command blocks in README.md" >&2; exit 1; }
grep -q 'scripts/test.sh' "${blocks[0]}" || { echo "readme: the first block must be the two commands" >&2; exit 1; }
status=0
for block in "${blocks[@]:1}"; do
  name=$(basename "$block" .sh)
  echo "== README $name"
  sed 's/^/   /' "$block"
  if ! (cd "$scratch" && timeout 600 bash -euo pipefail "$block") >"$scratch/$name.log" 2>&1; then
    echo "readme: $name failed as written:" >&2
    tail -20 "$scratch/$name.log" >&2
    status=1
  fi
done
((status == 0)) && echo "readme: all $((${#blocks[@]} - 1)) command blocks ran as written"
exit $status
