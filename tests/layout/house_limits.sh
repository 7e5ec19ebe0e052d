#!/usr/bin/env bash
# The house's limits (scripts/house_limits.py) on the tree, then the check's own power to fail: a
# small tree with one of each thing over a limit must give each problem, and nothing else.
# Usage: house_limits.sh SOURCE_DIR
set -euo pipefail
source_dir=$(cd "$1" && pwd)
check="$source_dir/scripts/house_limits.py"
python3 "$check" "$source_dir"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work"/{host,sim,rtl,tests/layout,tests/area}
body() { for ((i = 0; i < $1; i++)); do echo "  x += $i;  // a { brace in a comment"; done; }
{
  echo 'namespace delta {'
  echo 'namespace {'
  echo 'int within() {'; body 118; echo '}'                              # 120 lines: within
  echo 'int too_long(int x) {'; body 119; echo '  return x;'; echo '}'  # 122 lines
  echo 'struct S {'
  echo '  S(int a) : a_(a), b_{a} {'; body 119; echo '  }'               # a constructor, 121 lines
  echo '  int a_, b_;'
  echo '};'
  echo '// house: table'
  echo 'int table() {'; body 130; echo '}'                                # excepted
  echo 'const char* text = "}}}";'
  echo '}  // namespace'
  echo '}  // namespace delta'
} >"$work/host/a.cpp"
{
  echo 'const auto registered = [](int x) {'; body 121; echo '  return x;'; echo '};'
} >"$work/sim/b.cpp"
printf 'module m;\n  // %0101d\nendmodule\n' 0 >"$work/rtl/m.sv"
printf 'TEST(Defect07, Something) {}\nTEST(Good, ChecksAThing) {}\n' >"$work/tests/area/test_x.cpp"
: >"$work/tests/area.cmake"
: >"$work/tests/unlisted.cmake"
printf '| `area.cmake` | what it checks |\n' >"$work/tests/README.md"

expect() {  # expect PATTERN: one problem line matches it
  grep -qE -- "$1" <<<"$out" || { echo "house limits: no problem matching '$1' in:"$'\n'"$out" >&2; exit 1; }
}
out=$(python3 "$check" "$work") && { echo "house limits: a tree over every limit passed" >&2; exit 1; }
expect '^host/a.cpp:[0-9]+: function too_long is 122 lines \(limit 120\)'
expect '^host/a.cpp:[0-9]+: function S is 121 lines'
expect '^sim/b.cpp:1: function registered is 124 lines'
expect '^rtl/m.sv:2: 1 lines over 100 columns'
expect '^tests/area/test_x.cpp:1: test Defect07.Something:'
expect 'tests/unlisted.cmake is not in its table'
[[ $(wc -l <<<"$out") -eq 6 ]] || { echo "house limits: expected 6 problems, got:"$'\n'"$out" >&2; exit 1; }

# The known list holds a figure and no more, and only shrinks.
printf 'functions host/a.cpp:too_long 122\nfunctions host/a.cpp:S 121\nfunctions sim/b.cpp:registered 124\n' \
  >"$work/tests/layout/house_limits_known.txt"
printf 'rtl-columns rtl/m.sv 1\nfunctions host/a.cpp:gone 200\n' >>"$work/tests/layout/house_limits_known.txt"
printf '| `unlisted.cmake` | x |\n' >>"$work/tests/README.md"
printf 'TEST(Good, ChecksAThing) {}\n' >"$work/tests/area/test_x.cpp"
out=$(python3 "$check" "$work") && { echo "house limits: a known line for a function that is gone passed" >&2; exit 1; }
expect 'house_limits_known.txt:5: functions host/a.cpp:gone is within the limit now \(or gone\): remove the line'
[[ $(wc -l <<<"$out") -eq 1 ]] || { echo "house limits: expected 1 problem, got:"$'\n'"$out" >&2; exit 1; }
sed -i '/gone/d; s/too_long 122/too_long 121/' "$work/tests/layout/house_limits_known.txt"
out=$(python3 "$check" "$work") && { echo "house limits: a function grown past its known figure passed" >&2; exit 1; }
expect 'function too_long is 122 lines .*more than the 121'
sed -i 's/too_long 121/too_long 130/' "$work/tests/layout/house_limits_known.txt"
out=$(python3 "$check" "$work") && { echo "house limits: a known figure above the function passed" >&2; exit 1; }
expect 'still allows 130: lower it to 122'
sed -i 's/too_long 130/too_long 122/' "$work/tests/layout/house_limits_known.txt"
python3 "$check" "$work" >/dev/null || { echo "house limits: the tree at its known figures failed" >&2; exit 1; }
echo "house limits: the tree within its limits; the check fails on each kind of excess"
