#!/usr/bin/env bash
# The layout shows the architecture: hls/ holds only synthesizable C++ and its
# C-simulation testbenches, rtl/ SystemVerilog, harnesses and the FPGA flow; neither includes the
# command line (CLI11, command.hpp) nor the host's table or plot code; nothing under hls/
# computes in float or double. The command line is host/cli/ alone, and the host's wings depend only
# downwards. Prints every offending line; exit 1 if there is one.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
status=0
if grep -rn -E '#include *[<"](CLI/|delta/(command|table|plot)\.hpp)' hls rtl; then
  echo "layout: hls/ or rtl/ includes command-line, table or plot code (move it to host/)" >&2
  status=1
fi
# float/double as a type or a cast, outside comments.
if grep -rn -E '\b(double|float)\b' hls --include='*.cpp' --include='*.hpp' --include='*.h' |
   grep -v -E '^[^:]+:[0-9]+: *//' | grep -v -E '//.*\b(double|float)\b' ; then
  echo "layout: float or double under hls/ (coefficients and constants as integer codes)" >&2
  status=1
fi
# The docs are for users: no issue numbers in README.md, docs/ or any folder's README (history is git's).
if git ls-files '*.md' | xargs grep -n -E '\b[Ii]ssues? #?[0-9]+' ; then
  echo "layout: a page for users names an issue number (say what it is; history belongs in git)" >&2
  status=1
fi
# The command line is host/cli/ alone: nothing else includes CLI11 or the command registry.
if grep -rn -E '#include *[<"](CLI/|command\.hpp|options\.hpp|delta/(command|options)\.hpp)' host hls rtl sim tests \
     --include='*.cpp' --include='*.hpp' --include='*.h' | grep -v -E '^host/cli/'; then
  echo "layout: CLI11 or the command registry outside host/cli/ (a command belongs in host/cli/)" >&2
  status=1
fi
# The host's wings depend only downwards (host/README.md): each may include the core
# (delta/*.hpp, delta/io, delta/link, delta/motion) and the wings listed for it, never a sideways one.
declare -A allowed=(
  [nn]="nn"
  [golden]="golden nn"
  [joint_control]="control golden nn"
  [diagnosis]="diagnosis"
  [controller]="controller golden nn"
  [deploy]="deploy golden nn"
  [cosim]="cosim controller golden nn rtl"
)
for wing in "${!allowed[@]}"; do
  pattern=$(tr ' ' '|' <<<"${allowed[$wing]}")
  if grep -rn -E '#include *"delta/[a-z_]+/' "host/$wing" --include='*.cpp' --include='*.hpp' |
     grep -v -E "#include *\"delta/(io|link|motion|${pattern})/"; then
    echo "layout: host/$wing/ includes a wing it may not (allowed: ${allowed[$wing]} and the core)" >&2
    status=1
  fi
done
if ((status == 0)); then
  echo "layout: hls/ and rtl/ include no command-line, table or plot code; no float or double under hls/;"
  echo "layout: CLI11 only in host/cli/; the host's wings depend only downwards"
fi
exit $status
