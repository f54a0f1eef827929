#!/usr/bin/env bash
# Rerun one blind fault of a round (s17, s18, ...) against the embedded reference drive.
#   run.sh ROUND base                 baseline: build, run all vectors -> ROUND/results/base.json
#   run.sh ROUND NN [drivecheck args] apply ROUND/hand-NN.patch, build, run ->
#                                     ROUND/results/hand-NN[-tag].json, diff against
#                                     ROUND/results/base.json, revert the worktree
#   e.g. run.sh s18 07 --profile cia402-alternative     (TAG=alt run.sh s18 07 --profile ...)
# A patch applies to the commit its round was written against (ROUND/README.md names it).
# Env: WT (required: a scratch git worktree of this repository; the script runs
# `git checkout -- .` there, so never point it at your working copy), TAG (suffix of the
# result files). ccache is used when CCACHE_DIR is set.
set -euo pipefail
ROUND=$(cd "$(dirname "$0")/${1:?name the round, e.g. s18}" && pwd)
shift
WT=${WT:?set WT to a scratch git worktree of this repository (git worktree add ...)}
OUT=$ROUND/results
mkdir -p "$OUT"
if [ -n "${CCACHE_DIR:-}" ]; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache CMAKE_C_COMPILER_LAUNCHER=ccache
fi
cd "$WT"
[ -f build/dev/build.ninja ] || cmake --preset dev >/dev/null
id=$1; shift
suffix=${TAG:+-$TAG}
git checkout -- .
trap 'git -C "$WT" checkout -- .' EXIT
if [ "$id" = base ]; then
  name=base$suffix
else
  git apply "$ROUND/hand-$id.patch"
  name=hand-$id$suffix
fi
nice -n 10 ninja -C build/dev -j2 drivecheck >"$OUT/$name.build.log" 2>&1 ||
  { echo "build failed: $OUT/$name.build.log"; exit 3; }
set +e
nice -n 10 build/dev/cli/drivecheck run --color never --json "$OUT/$name.json" "$@" >"$OUT/$name.run.log" 2>&1
rc=$?
set -e
echo "$name: drivecheck run exit $rc (log $OUT/$name.run.log)"
if [ "$id" != base ]; then
  base=$OUT/base$suffix.json
  build/dev/cli/drivecheck report diff "$base" "$OUT/$name.json" >"$OUT/$name.diff.txt" 2>&1 || true
  cat "$OUT/$name.diff.txt"
fi
