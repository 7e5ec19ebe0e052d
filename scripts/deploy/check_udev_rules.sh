#!/usr/bin/env bash
# Checks host/deploy/udev/70-delta-board.rules (CTest Deploy.UdevRules): every line a comment, a
# label or a rule of `KEY=="value"` / `KEY="value"` / `KEY+="value"` / `KEY-="value"` terms (Debian
# 12's udevadm has no `verify`; with a newer udevadm the file is verified too), and the keys the
# board needs: the FT2232H (0403:6010), interface 01 as /dev/delta-board for the service's group
# deltactl only, latency_timer 1, ModemManager ignoring it; and who else reaches it: no uaccess (the
# seat's user) and no plugdev anywhere, fpga-icestorm's uaccess tag removed from every node, the
# USB device (usbfs, the programmer) for group deltactl-flash only, channel A's tty for root only.
set -euo pipefail
rules=${1:?usage: check_udev_rules.sh RULES}
fail() { echo "FAIL: $rules: $*" >&2; exit 1; }
term='[A-Za-z_]+(\{[A-Za-z0-9_]+\})?(==|!=|=|\+=|-=|:=)"[^"]*"'
n=0
while IFS= read -r line || [[ -n "$line" ]]; do
  n=$((n + 1))
  [[ -z "$line" || "$line" =~ ^# || "$line" =~ ^LABEL=\"[a-z_]+\"$ ]] && continue
  [[ "$line" =~ ^($term)(,\ ($term))*$ ]] || fail "line $n is not a list of KEY op \"value\" terms: $line"
done <"$rules"
uart=$(grep -E 'SYMLINK\+="delta-board"' "$rules") || fail "no rule making /dev/delta-board"
for key in 'SUBSYSTEM=="tty"' 'ATTRS{idVendor}=="0403"' 'ATTRS{idProduct}=="6010"' 'ENV{ID_USB_INTERFACE_NUM}=="01"' \
           'GROUP="deltactl"' 'MODE="0660"'; do
  [[ "$uart" == *"$key"* ]] || fail "the /dev/delta-board rule lacks $key"
done
latency=$(grep -F 'ATTR{latency_timer}="1"' "$rules") || fail "no latency_timer=1 rule"
for key in 'SUBSYSTEM=="usb-serial"' 'ATTRS{bInterfaceNumber}=="01"' 'ATTRS{idProduct}=="6010"'; do
  [[ "$latency" == *"$key"* ]] || fail "the latency_timer rule lacks $key"
done
rules_only=$(grep -v '^#' "$rules")
if grep -q 'uaccess"' <<<"$(grep -E 'TAG\+?=' <<<"$rules_only")"; then fail "a rule gives the seat's user (uaccess) access"; fi
if grep -q 'plugdev' <<<"$rules_only"; then fail "a rule gives plugdev access"; fi
every=$(grep -F 'TAG-="uaccess"' <<<"$rules_only") || fail "fpga-icestorm's uaccess tag is not removed"
[[ "$every" == *'ATTRS{idVendor}=="0403"'* && "$every" == *'ATTRS{idProduct}=="6010"'* && "$every" != *SUBSYSTEM* ]] ||
  fail "the uaccess removal does not cover every node of 0403:6010: $every"
[[ "$every" == *'ENV{ID_MM_DEVICE_IGNORE}="1"'* ]] || fail "ModemManager is not told to ignore the board"
programmer=$(grep -E 'SUBSYSTEM=="usb",' <<<"$rules_only") || fail "no rule for the USB device (programmer)"
for key in 'ENV{DEVTYPE}=="usb_device"' 'ATTR{idVendor}=="0403"' 'ATTR{idProduct}=="6010"' 'GROUP="deltactl-flash"' \
           'MODE="0660"'; do
  [[ "$programmer" == *"$key"* ]] || fail "the USB device rule lacks $key"
done
channel_a=$(grep -F 'ENV{ID_USB_INTERFACE_NUM}=="00"' <<<"$rules_only") || fail "no rule for channel A's tty"
[[ "$channel_a" == *'GROUP="root"'* && "$channel_a" == *'MODE="0600"'* ]] || fail "channel A's tty is not root's only"
# A GOTO needs its LABEL.
for label in $(grep -o 'GOTO="[a-z_]*"' "$rules" | cut -d'"' -f2); do
  grep -q "^LABEL=\"$label\"$" "$rules" || fail "GOTO=\"$label\" without LABEL"
done
if udevadm verify --help >/dev/null 2>&1; then
  udevadm verify --no-style "$rules" >/dev/null || fail "udevadm verify"
fi
echo "PASS: $rules: $n lines; /dev/delta-board (interface 01, group deltactl), latency_timer 1, MM ignore;" \
  "no uaccess or plugdev; usbfs for deltactl-flash; channel A root only"
