#!/bin/sh
# Runs inside the test VM (tests/vm/run-in-vm, drivecheck as --extra, the reference drive's
# EDS as --data): the live fuzzer over SocketCAN against `drivecheck drive` on vcan0, as two
# processes, the way a user fuzzes a real drive.
#   1. the standard drive: nothing found (exit 0);
#   2. the drive with the fatal SDO hang: found (exit 1), saved as a candump log; minimising
#      is skipped with a note, since a real device that stays hung cannot be reset to a fresh
#      state;
#   3. the saved log replayed against a fresh hung-to-be drive reproduces (exit 1) and against
#      a fresh standard drive does not (exit 0).
#   live_fuzz_in_vm.sh EDS VECTORS
# VECTORS: the vector tree with the drive profiles (copied in with --data: the binary alone is
# in /bin, without the share/drivecheck folder it finds its data in elsewhere).
set -u
eds=${1:?usage: live_fuzz_in_vm.sh EDS VECTORS}
DRIVECHECK_VECTORS=${2:?usage: live_fuzz_in_vm.sh EDS VECTORS}
export DRIVECHECK_VECTORS
out=/tmp/live-fuzz
mkdir -p "$out"
failed=0

start_drive() {  # start_drive LOG [--deviation NAME]
  drive_log=$1
  shift
  drivecheck drive --bus socketcan:vcan0 --node 1 "$@" > "$drive_log" 2>&1 &
  drive=$!
  sleep 1
  if ! kill -0 "$drive" 2>/dev/null; then
    echo "live_fuzz_in_vm: drivecheck drive did not start:"; cat "$drive_log"; exit 1
  fi
}
stop_drive() {
  kill "$drive" 2>/dev/null
  wait "$drive" 2>/dev/null
}
fuzz() {  # fuzz OUT ARGS...: the fuzzer against node 1 on vcan0; sets status
  dir=$1
  shift
  drivecheck fuzz --bus socketcan:vcan0 --node 1 --eds "$eds" --seed 1 --out "$dir" "$@" \
    > "$dir.txt" 2>&1
  status=$?
  tail -6 "$dir.txt"
}
expect() {  # expect WHAT WANTED GOT
  if [ "$2" != "$3" ]; then
    echo "live_fuzz_in_vm: FAILED: $1: exit $3, expected $2"
    failed=1
  else
    echo "live_fuzz_in_vm: ok: $1 (exit $3)"
  fi
}

start_drive "$out/standard-drive.log"
fuzz "$out/standard" --duration 15s
stop_drive
expect "the standard drive shows no anomaly" 0 "$status"

start_drive "$out/hang-drive.log" --deviation fatal-sdo-hang-on-missing-sub
fuzz "$out/hang" --duration 60s --max-cases 60
stop_drive
expect "the SDO hang is found" 1 "$status"
reproducer=$(ls "$out"/hang/anomaly-1-sdo-no-answer.log 2>/dev/null)
if [ -z "$reproducer" ]; then
  echo "live_fuzz_in_vm: FAILED: no sdo-no-answer reproducer in $out/hang:"; ls "$out/hang"
  exit 1
fi
grep -q " T$" "$reproducer" ||
  { echo "live_fuzz_in_vm: FAILED: $reproducer has no harness frames"; failed=1; }

start_drive "$out/replay-hang-drive.log" --deviation fatal-sdo-hang-on-missing-sub
fuzz "$out/replay-hang" --replay "$reproducer"
stop_drive
expect "the saved log reproduces the hang on a fresh drive with the deviation" 1 "$status"

start_drive "$out/replay-standard-drive.log"
fuzz "$out/replay-standard" --replay "$reproducer"
stop_drive
expect "the saved log does not reproduce on the standard drive" 0 "$status"

exit $failed
