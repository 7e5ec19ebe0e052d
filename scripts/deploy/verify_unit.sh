#!/usr/bin/env bash
# systemd-analyze verify of host/deploy/systemd/deltactl.service (CTest Deploy.SystemdUnit), with
# /usr/bin/deltactl pointed at the built one (verify needs ExecStart's binary), then the settings
# the issue asks for: Type=notify, WatchdogSec, Restart=on-failure, User=deltactl with dialout and
# plugdev, LimitRTPRIO, LimitMEMLOCK, ExecStart `host serve --config /etc/deltactl/deltactl.conf`.
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
for setting in 'Type=notify' 'WatchdogSec=' 'Restart=on-failure' 'User=deltactl' 'SupplementaryGroups=dialout plugdev' \
               'LimitRTPRIO=' 'LimitMEMLOCK=' \
               'ExecStart=/usr/bin/deltactl host serve --config /etc/deltactl/deltactl.conf'; do
  grep -q "^$setting" "$unit" || { echo "FAIL: $unit lacks $setting" >&2; exit 1; }
done
echo "PASS: systemd-analyze verify $unit (ExecStart -> $deltactl)"
