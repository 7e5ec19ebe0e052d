#!/usr/bin/env bash
# The companion package deltactl-gateware (Architecture: all): the iCEBreaker's bitstream and its
# identify.mem as /usr/share/deltactl/gateware/, where the deltactl package's configuration names
# them for `deltactl flash`. Version and maintainer come from the deltactl package's Debian
# changelog, so the two packages pair (deltactl depends on deltactl-gateware of its own version).
# Run by `cmake --build build --target gateware_package` (the full build: yosys, nextpnr-ice40,
# icepack) on the built bitstream; CTest Deploy.Package runs it on a stand-in.
# Usage: scripts/deploy/gateware_package.sh BITSTREAM IDENTIFY_MEM CHANGELOG COPYRIGHT OUT_DIR
set -euo pipefail
usage="usage: gateware_package.sh BITSTREAM IDENTIFY_MEM CHANGELOG COPYRIGHT OUT_DIR"
bitstream=${1:?$usage}
identify=${2:?$usage}
changelog=${3:?$usage}
copyright=${4:?$usage}
out=${5:?$usage}
fail() { echo "gateware_package: error: $*" >&2; exit 2; }
for file in "$bitstream" "$identify" "$changelog" "$copyright"; do [[ -f $file ]] || fail "$file: no such file"; done
version=$(sed -n '1s/^deltactl (\([^)]*\)).*/\1/p' "$changelog")
maintainer=$(sed -n 's/^ -- \(.*>\)  .*/\1/p' "$changelog" | head -1)
[[ -n $version && -n $maintainer ]] || fail "$changelog: no 'deltactl (VERSION)' first line or ' -- NAME <MAIL>  DATE' line"
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
data="$stage/usr/share/deltactl/gateware"
doc="$stage/usr/share/doc/deltactl-gateware"
mkdir -p "$data" "$doc" "$stage/DEBIAN"
install -m 644 "$bitstream" "$data/icebreaker_top.bin"
install -m 644 "$identify" "$data/identify.mem"
install -m 644 "$copyright" "$doc/copyright"
sed '/^deltactl (/s/^deltactl (/deltactl-gateware (/' "$changelog" | gzip -9n >"$doc/changelog.gz"
chmod 644 "$doc/changelog.gz"
size_kib=$(du -sk --exclude=DEBIAN "$stage" | cut -f1)
cat >"$stage/DEBIAN/control" <<CONTROL
Package: deltactl-gateware
Version: $version
Architecture: all
Maintainer: $maintainer
Installed-Size: $size_kib
Section: electronics
Priority: optional
Enhances: deltactl
Description: Delta robot gateware: the iCEBreaker bitstream for deltactl flash
 The iCE40 UP5K bitstream of the Delta robot's board (UART link, neural
 network inverse kinematics, joint controllers) and its identify payload
 (identify.mem: gateware build id, weights CRC-32), which deltactl flash
 checks against the installed deltactl and its configured weights.
CONTROL
(cd "$stage" && find usr -type f -exec md5sum {} + | sort -k2) >"$stage/DEBIAN/md5sums"
chmod 644 "$stage/DEBIAN/control" "$stage/DEBIAN/md5sums"
find "$stage" -type d -exec chmod 755 {} +
mkdir -p "$out"
deb="$out/deltactl-gateware_${version}_all.deb"
dpkg-deb --root-owner-group -Zxz --build "$stage" "$deb" >/dev/null
echo "gateware_package: $deb ($(du -h "$deb" | cut -f1)): $(basename "$bitstream") and identify.mem"
