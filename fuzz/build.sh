#!/bin/bash -eu
# OSS-Fuzz / ClusterFuzzLite build script: builds every fuzz target of drivecheck with the
# compiler, flags and engine the infrastructure passes, and installs into $OUT, for each target
# <name> (fuzz/<name>_fuzzer.cpp):
#   $OUT/<name>_fuzzer                  the fuzzer, linked with $LIB_FUZZING_ENGINE
#   $OUT/<name>_fuzzer_seed_corpus.zip  fuzz/corpus/<name>/ (flat)
#   $OUT/<name>_fuzzer.dict             fuzz/<name>.dict
#   $OUT/<name>_fuzzer.options          fuzz/<name>_fuzzer.options (its dict= names the .dict)
#
# Environment (OSS-Fuzz conventions): CXX, CXXFLAGS, LIB_FUZZING_ENGINE, OUT required; WORK
# (scratch; the CMake build goes to $WORK/drivecheck-fuzz and is reused); SRC is not needed
# (the sources are found from this script's place). DRIVECHECK_JOBS: build parallelism
# (default: all cores). CC/CFLAGS are accepted and unused (drivecheck is C++ only).
#
# Local use (what the CTest fuzz.oss-fuzz-build does):
#   CXX=clang++-19 CXXFLAGS="-fsanitize=address,fuzzer-no-link" \
#   LIB_FUZZING_ENGINE=-fsanitize=fuzzer OUT=/tmp/out WORK=/tmp/work fuzz/build.sh
# Note for OSS-Fuzz proper: its CXXFLAGS carry -stdlib=libc++, so the Dockerfile must build fmt
# (and the other libraries the targets link) with libc++; Debian's libfmt-dev is libstdc++.
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
: "${CXX:?}" "${LIB_FUZZING_ENGINE:?}" "${OUT:?}"
CXXFLAGS="${CXXFLAGS:-}"
work="${WORK:-${TMPDIR:-/tmp}}/drivecheck-fuzz"
jobs="${DRIVECHECK_JOBS:-$(nproc)}"

generator=()
if command -v ninja > /dev/null; then generator=(-G Ninja); fi
cmake -S "$root" -B "$work" "${generator[@]}" \
  -DCMAKE_BUILD_TYPE= \
  -DCMAKE_CXX_COMPILER="$CXX" \
  -DCMAKE_CXX_FLAGS="$CXXFLAGS" \
  -DDRIVECHECK_FUZZ_ENGINE="$LIB_FUZZING_ENGINE" \
  -DDRIVECHECK_BUILD_TESTS=OFF \
  -DDRIVECHECK_BUILD_BENCH=OFF
cmake --build "$work" --target drivecheck_fuzzers --parallel "$jobs"

mkdir -p "$OUT"
count=0
while read -r name; do
  [[ -n $name ]] || continue
  corpus="$root/fuzz/corpus/$name"
  for f in "$work/fuzz/${name}_fuzzer" "$root/fuzz/$name.dict" "$root/fuzz/${name}_fuzzer.options"; do
    [[ -f $f ]] || { echo "build.sh: $f is missing" >&2; exit 1; }
  done
  cp "$work/fuzz/${name}_fuzzer" "$OUT/"
  cp "$root/fuzz/$name.dict" "$OUT/${name}_fuzzer.dict"
  cp "$root/fuzz/${name}_fuzzer.options" "$OUT/"
  zip_file="$OUT/${name}_fuzzer_seed_corpus.zip"
  rm -f "$zip_file"
  mapfile -t seeds < <(find "$corpus" -maxdepth 1 -type f ! -name 'README*' ! -name '.*' | sort)
  ((${#seeds[@]})) || { echo "build.sh: $corpus holds no seeds" >&2; exit 1; }
  if command -v zip > /dev/null; then
    zip -q -j "$zip_file" "${seeds[@]}"
  else
    (cd "$corpus" && cmake -E tar cf "$zip_file" --format=zip "${seeds[@]##*/}")
  fi
  count=$((count + 1))
done < "$work/fuzz/fuzzers.txt"
# The cia402 target impersonates the manuals' drives: their profiles go next to the fuzzers
# (cia402_fuzzer.cpp looks for <its folder>/drives).
rm -rf "$OUT/drives"
cp -r "$root/vectors/drives" "$OUT/drives"
echo "build.sh: $count fuzz targets installed in $OUT"
