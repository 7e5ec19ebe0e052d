#!/usr/bin/env bash
# systemd-analyze verify of host/deploy/systemd/deltactl.service (CTest Deploy.SystemdUnit), with
# /usr/bin/deltactl pointed at the built one (verify needs ExecStart's binary), then the settings
# the issue asks for: Type=notify, WatchdogSec, Restart=on-failure (not on exit 2, a bad
# configuration), User=deltactl, LimitRTPRIO and LimitMEMLOCK (the real-time thread: no
# RestrictRealtime, and @resources allowed), ExecStart `host serve --config /etc/deltactl/deltactl.conf`;
# the sandbox: `systemd-analyze security --offline=true` exposure below 5.0, devices the USB UART
# only, no capabilities, UMask 0027, IP to localhost only.
set -euo pipefail
unit=${1:?usage: verify_unit.sh UNIT DELTACTL}
deltactl=${2:?usage: verify_unit.sh UNIT DELTACTL}
command -v systemd-analyze >/dev/null || { echo "SKIP: no systemd-analyze (apt install systemd)"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sed "s#/usr/bin/deltactl#$deltactl#g" "$unit" >"$work/deltactl.service"
if ! SYSTEMD_LOG_LEVEL=warning systemd-analyze verify --man=no "$work/deltactl.service" >"$work/log" 2>&1; then
  cat "$work/log" >&2; echo "FAIL: systemd-analyze verify" >&2; exit 1
fi
# verify exits 0 on some complaints: any line naming the unit is one.
if grep -F "deltactl.service" "$work/log" >&2; then echo "FAIL: systemd-analyze verify complained" >&2; exit 1; fi
for setting in 'Type=notify' 'WatchdogSec=' 'Restart=on-failure' 'RestartPreventExitStatus=2' 'User=deltactl' \
               'Group=deltactl' 'LimitRTPRIO=' 'LimitMEMLOCK=infinity' \
               'ExecStart=/usr/bin/deltactl host serve --config /etc/deltactl/deltactl.conf' \
               'DevicePolicy=closed' 'DeviceAllow=char-ttyUSB rw' 'CapabilityBoundingSet=$' 'UMask=0027' \
               'IPAddressDeny=any' 'IPAddressAllow=localhost' 'SystemCallFilter=@system-service'; do
  grep -q "^$setting" "$unit" || { echo "FAIL: $unit lacks $setting" >&2; exit 1; }
done
# The real-time thread needs sched_setscheduler (@resources) and mlockall (@memlock).
for blocker in 'RestrictRealtime=yes' 'SystemCallFilter=~.*@resources' 'SystemCallFilter=~.*@memlock' \
               'PrivateNetwork=yes' 'SupplementaryGroups=.*plugdev'; do
  if grep -Eq "^$blocker" "$unit"; then echo "FAIL: $unit has $blocker" >&2; exit 1; fi
done
systemd-analyze security --offline=true "$work/deltactl.service" >"$work/security" 2>&1 || true
exposure=$(sed -n 's/.*Overall exposure level for deltactl.service: \([0-9.]*\).*/\1/p' "$work/security")
[[ -n $exposure ]] || { cat "$work/security" >&2; echo "FAIL: no exposure level from systemd-analyze security" >&2; exit 1; }
awk -v e="$exposure" 'BEGIN { exit !(e < 5.0) }' || {
  grep '✗' "$work/security" >&2; echo "FAIL: exposure $exposure, not below 5.0" >&2; exit 1; }
echo "PASS: systemd-analyze verify $unit (ExecStart -> $deltactl); security exposure $exposure (below 5.0)"
