#!/usr/bin/env bash
# The deltactl package's maintainer scripts (CTest Deploy.MaintainerScripts), run against stand-ins:
# systemctl, deb-systemd-invoke, deb-systemd-helper, adduser, addgroup, deluser, delgroup, getent,
# id and udevadm on PATH log their arguments; /run/systemd/system, /run/udev and /var/lib/deltactl
# are moved into a scratch folder. Checks: an upgrade never stops the service in prerm and
# try-restarts it in postinst; a remove stops it; a fresh install creates the user, the groups
# deltactl and deltactl-flash and starts the service; the service user leaves dialout and plugdev;
# purge keeps /var/lib/deltactl/runs (owned by root) and deletes the rest, unless
# DELTACTL_PURGE_RECORDINGS=yes, which deletes the recordings too.
# Usage: scripts/deploy/maintainer_scripts_test.sh DEBIAN_DIR
set -euo pipefail
debian=${1:?usage: maintainer_scripts_test.sh DEBIAN_DIR}
fail() { echo "FAIL: $*" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/bin" "$work/run/systemd/system" "$work/run/udev" "$work/var/lib"
log="$work/calls.log"
for tool in systemctl deb-systemd-invoke deb-systemd-helper adduser addgroup deluser delgroup udevadm chown; do
  printf '#!/bin/sh\necho "%s $*" >>"%s"\n' "$tool" "$log" >"$work/bin/$tool"
done
# getent: the user and groups exist when $work/exists names them; id: the service user's groups.
printf '#!/bin/sh\necho "getent $*" >>"%s"\ngrep -qx "$1 $2" "%s/exists"\n' "$log" "$work" >"$work/bin/getent"
printf '#!/bin/sh\necho "deltactl dialout plugdev"\n' >"$work/bin/id"
# deb-systemd-helper was-enabled: a fresh install (no state) says yes, as the real one does.
chmod +x "$work/bin"/*
for script in postinst prerm postrm; do
  sed -e "s#/run/systemd/system#$work/run/systemd/system#g" -e "s#/run/udev#$work/run/udev#g" \
      -e "s#/var/lib/deltactl#$work/var/lib/deltactl#g" -e "s#/usr/bin/deb-systemd-helper#$work/bin/deb-systemd-helper#g" \
      "$debian/$script" >"$work/$script"
done
run() {  # run SCRIPT ARGS...: a fresh log, the script's exit status must be 0
  : >"$log"
  PATH="$work/bin:$PATH" sh -e "$work/$1" "${@:2}" >"$work/out" 2>&1 || { cat "$work/out" >&2; fail "$* exited non-zero"; }
}
called() { grep -qx "$1" "$log"; }

# Upgrade from 0.1.0: the old prerm's "upgrade", then the new postinst's "configure 0.1.0".
printf 'passwd deltactl\ngroup deltactl\ngroup deltactl-flash\n' >"$work/exists"
run prerm upgrade 0.1.1
if grep -q ' stop deltactl.service' "$log"; then fail "prerm upgrade stops the service: $(cat "$log")"; fi
run postinst configure 0.1.0
called "deb-systemd-invoke try-restart deltactl.service" || fail "postinst on upgrade does not try-restart: $(cat "$log")"
if grep -q 'deb-systemd-invoke start' "$log"; then fail "postinst on upgrade starts a stopped service"; fi
if grep -q '^adduser --system' "$log"; then fail "postinst on upgrade makes the user again"; fi
called "deluser --quiet deltactl dialout" || fail "the service user stays in dialout: $(cat "$log")"
called "deluser --quiet deltactl plugdev" || fail "the service user stays in plugdev: $(cat "$log")"

# Remove: prerm stops the service.
run prerm remove
called "deb-systemd-invoke stop deltactl.service" || fail "prerm remove does not stop the service: $(cat "$log")"

# Fresh install: user and groups made, the service enabled and started.
: >"$work/exists"
run postinst configure
grep -q '^adduser --system --group .* deltactl$' "$log" || fail "no system user deltactl: $(cat "$log")"
called "addgroup --system --quiet deltactl-flash" || fail "no group deltactl-flash: $(cat "$log")"
called "deb-systemd-helper enable deltactl.service" || fail "not enabled: $(cat "$log")"
called "deb-systemd-invoke start deltactl.service" || fail "not started: $(cat "$log")"

# Purge: the recordings stay (root's), the rest goes.
state="$work/var/lib/deltactl"
mkdir -p "$state/runs" "$state/cache"
echo "t_s" >"$state/runs/run-1.csv"
echo x >"$state/other"
printf 'passwd deltactl\ngroup deltactl\ngroup deltactl-flash\n' >"$work/exists"
run postrm purge
[[ -f $state/runs/run-1.csv ]] || fail "purge deleted the recordings"
[[ ! -e $state/other && ! -e $state/cache ]] || fail "purge kept more than the recordings: $(ls "$state")"
called "chown -R root:root $state/runs" || fail "the kept recordings are not handed to root: $(cat "$log")"
called "chown root:root $state" || fail "the kept $state is not handed to root: $(cat "$log")"
grep -q "the recordings stay in $state/runs" "$work/out" || fail "purge does not say where the recordings are"
called "deluser --quiet --system deltactl" || fail "purge keeps the user"
DELTACTL_PURGE_RECORDINGS=yes run postrm purge
[[ ! -e $state ]] || fail "DELTACTL_PURGE_RECORDINGS=yes purge kept $state"
echo "PASS: upgrade: no stop, try-restart; remove: stop; install: user, groups, start; purge keeps runs/ unless asked"
