#!/usr/bin/env bash
# Checks host/deploy/udev/70-delta-board.rules (CTest Deploy.UdevRules): every line a comment, a
# label or a rule of `KEY=="value"` / `KEY="value"` / `KEY+="value"` terms (Debian 12's udevadm has
# no `verify`; with a newer udevadm the file is verified too), and the keys the board needs: the
# FT2232H (0403:6010), interface 01 as /dev/delta-board for dialout, latency_timer 1, ModemManager
# ignoring it, the programmer for plugdev.
set -euo pipefail
rules=${1:?usage: check_udev_rules.sh RULES}
fail() { echo "FAIL: $rules: $*" >&2; exit 1; }
term='[A-Za-z_]+(\{[A-Za-z0-9_]+\})?(==|!=|=|\+=|:=)"[^"]*"'
n=0
while IFS= read -r line || [[ -n "$line" ]]; do
  n=$((n + 1))
  [[ -z "$line" || "$line" =~ ^# || "$line" =~ ^LABEL=\"[a-z_]+\"$ ]] && continue
  [[ "$line" =~ ^($term)(,\ ($term))*$ ]] || fail "line $n is not a list of KEY op \"value\" terms: $line"
done <"$rules"
uart=$(grep -E 'SYMLINK\+="delta-board"' "$rules") || fail "no rule making /dev/delta-board"
for key in 'SUBSYSTEM=="tty"' 'ATTRS{idVendor}=="0403"' 'ATTRS{idProduct}=="6010"' 'ENV{ID_USB_INTERFACE_NUM}=="01"' \
           'GROUP="dialout"' 'ENV{ID_MM_DEVICE_IGNORE}="1"'; do
  [[ "$uart" == *"$key"* ]] || fail "the /dev/delta-board rule lacks $key"
done
latency=$(grep -F 'ATTR{latency_timer}="1"' "$rules") || fail "no latency_timer=1 rule"
for key in 'SUBSYSTEM=="usb-serial"' 'ATTRS{bInterfaceNumber}=="01"' 'ATTRS{idProduct}=="6010"'; do
  [[ "$latency" == *"$key"* ]] || fail "the latency_timer rule lacks $key"
done
programmer=$(grep -E 'SUBSYSTEM=="usb".*GROUP="plugdev"' "$rules") || fail "no plugdev rule for the programmer"
[[ "$programmer" == *'ATTR{idVendor}=="0403"'* && "$programmer" == *'ATTR{idProduct}=="6010"'* ]] ||
  fail "the programmer rule does not match 0403:6010"
# A GOTO needs its LABEL.
for label in $(grep -o 'GOTO="[a-z_]*"' "$rules" | cut -d'"' -f2); do
  grep -q "^LABEL=\"$label\"$" "$rules" || fail "GOTO=\"$label\" without LABEL"
done
if udevadm verify --help >/dev/null 2>&1; then
  udevadm verify --no-style "$rules" >/dev/null || fail "udevadm verify"
fi
echo "PASS: $rules: $n lines; /dev/delta-board (interface 01, dialout, MM ignore), latency_timer 1, programmer plugdev"
