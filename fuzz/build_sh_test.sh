#!/usr/bin/env bash
# CTest fuzz.oss-fuzz-build: runs fuzz/build.sh the way OSS-Fuzz does (clang-19, ASan,
# LIB_FUZZING_ENGINE=-fsanitize=fuzzer, a fresh $OUT) and checks what it installed: for every
# fuzz/<name>_fuzzer.cpp a fuzzer binary, its dictionary, its options (naming that dictionary)
# and a seed corpus zip holding every seed; then each fuzzer loads its dictionary and runs its
# unzipped seeds once (-runs=0).
#
#   fuzz/build_sh_test.sh WORK_DIR     (WORK_DIR is kept: later runs rebuild incrementally)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
work="${1:?usage: build_sh_test.sh WORK_DIR}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

export CC=clang-19 CXX=clang++-19
# OSS-Fuzz's address-sanitizer flags, plus UBSan as in the fuzz preset: scripts/test runs the
# fuzz smoke run on this very build (WORK_DIR/drivecheck-fuzz) instead of compiling every
# target a second time, so it must catch what the fuzz preset catches.
export CFLAGS="-O1 -fno-omit-frame-pointer -gline-tables-only -fsanitize=address \
-fsanitize-address-use-after-scope -fsanitize=undefined -fno-sanitize-recover=undefined \
-fsanitize=fuzzer-no-link"
export CXXFLAGS="$CFLAGS"
export LIB_FUZZING_ENGINE=-fsanitize=fuzzer
export OUT="$out/out" WORK="$work" SRC="$(dirname "$root")" DRIVECHECK_JOBS=2
"$root/fuzz/build.sh"

fail() { echo "build_sh_test: $*" >&2; exit 1; }
count=0
for source in "$root"/fuzz/*_fuzzer.cpp; do
  name="$(basename "$source" _fuzzer.cpp)"
  fuzzer="$OUT/${name}_fuzzer"
  [[ -x $fuzzer ]] || fail "$fuzzer missing or not executable"
  [[ -f $OUT/${name}_fuzzer.dict ]] || fail "$name: dictionary missing"
  grep -qx "dict = ${name}_fuzzer.dict" "$OUT/${name}_fuzzer.options" ||
    fail "$name: options do not name ${name}_fuzzer.dict"
  zip_file="$OUT/${name}_fuzzer_seed_corpus.zip"
  [[ -f $zip_file ]] || fail "$name: seed corpus zip missing"
  seeds=$(find "$root/fuzz/corpus/$name" -maxdepth 1 -type f ! -name 'README*' | wc -l)
  unzipped="$out/seeds-$name"
  mkdir -p "$unzipped"
  unzip -q "$zip_file" -d "$unzipped"
  in_zip=$(find "$unzipped" -type f | wc -l)
  ((seeds > 0 && in_zip == seeds)) || fail "$name: zip holds $in_zip seeds, fuzz/corpus/$name $seeds"
  log="$out/$name.log"
  "$fuzzer" -runs=0 -dict="$OUT/${name}_fuzzer.dict" "$unzipped" > "$log" 2>&1 ||
    { cat "$log" >&2; fail "$name: the fuzzer failed on its seeds"; }
  grep -q "Dictionary: [1-9]" "$log" || { cat "$log" >&2; fail "$name: dictionary not loaded"; }
  grep -q "INITED" "$log" || { cat "$log" >&2; fail "$name: corpus not run"; }
  count=$((count + 1))
done
((count > 0)) || fail "no fuzz targets found"
# cia402 impersonates the manuals' drives from $OUT/drives (it looks beside itself first).
for profile in festo-cmmp kollmorgen-s300-s700 irtsa-drive-fb esr-triodrive; do
  [[ -f $OUT/drives/$profile.yaml ]] || fail "drives/$profile.yaml not installed"
done
if grep -q "run the standard drive" "$out/cia402.log"; then
  cat "$out/cia402.log" >&2
  fail "cia402: a personality's profile could not be read"
fi
echo "build_sh_test: $count targets built, installed and run on their seeds"
