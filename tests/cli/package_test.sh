#!/usr/bin/env bash
# CTest package.deb: the Debian package installs and runs from anywhere.
#   package_test.sh BUILD_DIR SOURCE_DIR
# Builds the package with cpack from BUILD_DIR (drivecheck must be built), unpacks it with
# dpkg-deb -x into a fresh folder, and runs the unpacked drivecheck from another working
# directory: `vectors list`, then `run` on the cia301/sdo family (the whole suite is the
# embedded default's own test). The unpacked binary must not mention the build machine's
# source folder, and the run must use the packaged profile (the report names its file).
set -euo pipefail
build=$1
source=$2
work=$(mktemp -d "${TMPDIR:-/tmp}/drivecheck-package-XXXXXX")
trap 'rm -rf "$work"' EXIT

cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/out" >"$work/cpack.log" 2>&1 ||
  { cat "$work/cpack.log"; exit 1; }
deb=$(ls "$work"/out/drivecheck_*.deb)
echo "package: $(basename "$deb") ($(du -k "$deb" | cut -f1) KiB)"
dpkg-deb -I "$deb" | sed -n 's/^ *Depends: /depends: /p'
dpkg-deb -x "$deb" "$work/root"
exe="$work/root/usr/bin/drivecheck"
test -x "$exe"
test -f "$work/root/usr/share/drivecheck/vectors/manuals.yaml"
test -f "$work/root/usr/share/drivecheck/vectors/drives/cia402-reference.yaml"
test -f "$work/root/usr/share/drivecheck/reference_drive.eds"

if grep -q -F -- "$source" "$exe"; then
  echo "FAIL: the packaged binary contains the source folder $source"
  exit 1
fi

mkdir -p "$work/elsewhere"
cd "$work/elsewhere"
"$exe" vectors list >list.txt
grep -q "cia301/sdo/" list.txt || { echo "FAIL: vectors list"; head list.txt; exit 1; }
set +e
"$exe" run --filter cia301/sdo --json report.json >run.txt 2>&1
code=$?
set -e
tail -n 1 run.txt
if ((code != 0)); then
  echo "FAIL: drivecheck run exited $code"
  cat run.txt
  exit 1
fi
grep -q '"cia301/sdo/' report.json || { echo "FAIL: no report"; exit 1; }
grep -q -F "$work/root/usr/share/drivecheck/vectors/drives/cia402-reference.yaml" report.json ||
  { echo "FAIL: the run did not use the packaged profile"; grep -o '"file": "[^"]*"' report.json; exit 1; }
echo "package: ok"
