#!/usr/bin/env bash
# Every tracked C++ file is laid out as .clang-format says (clang-format from Debian). Prints the
# files that are not and the command that fixes them; exit 1 if there is one.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
command -v clang-format >/dev/null || { echo "format: clang-format missing (bash scripts/setup.sh installs it)" >&2; exit 1; }
unformatted=()
while IFS= read -r file; do
  [[ -f $file ]] || continue
  clang-format --dry-run --Werror "$file" >/dev/null 2>&1 || unformatted+=("$file")
done < <(git ls-files '*.cpp' '*.hpp' '*.h' 2>/dev/null || find host sim hls tests -name '*.[ch]pp')
if ((${#unformatted[@]})); then
  printf 'format: not formatted: %s\n' "${unformatted[@]}" >&2
  echo "format: fix with: clang-format -i ${unformatted[*]}" >&2
  exit 1
fi
echo "format: every C++ file follows .clang-format"
