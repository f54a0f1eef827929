#!/bin/sh
# Runs inside the test VM (tests/vm/run-in-vm, with drivecheck as --extra and the vectors as
# --data): the reference drive as its own process on vcan0 (`drivecheck drive`), the suite
# against it over SocketCAN as another process (`drivecheck run --bus socketcan:vcan0`), and
# the same vectors against the embedded drive on the simulated bus. The two runs must give
# every vector the same verdict (`drivecheck report diff` lists no change), except that vectors
# needing simulated inputs are not applicable over SocketCAN.
#   conformance_in_vm.sh FILTER VECTORS
# VECTORS: the vector tree (copied into the VM with --data; the binary alone is in /bin, without
# the share/drivecheck folder it finds its data in elsewhere).
set -u
filter=${1:?usage: conformance_in_vm.sh FILTER VECTORS}
DRIVECHECK_VECTORS=${2:?usage: conformance_in_vm.sh FILTER VECTORS}
export DRIVECHECK_VECTORS
out=/tmp/conformance
mkdir -p "$out"

drivecheck drive --bus socketcan:vcan0 --node 1 > "$out/drive.log" 2>&1 &
drive=$!
sleep 1
if ! kill -0 "$drive" 2>/dev/null; then
  echo "conformance_in_vm: drivecheck drive did not start:"; cat "$out/drive.log"; exit 1
fi
# The drive stands in for a device, which is hardware of its own: in the VM's one CPU it runs
# before the harness (nice -20), so that the harness's own work never delays the device's
# frames. What the host's load does to the whole VM still reaches both.
renice -n -20 -p "$drive" > /dev/null ||
  echo "conformance_in_vm: note: could not raise the drive's priority"

# Reports: JSON only (what the diff reads) and the SocketCAN trace; the VM's /tmp is its RAM,
# and the whole suite's HTML and JUnit reports of two runs filled it.
# The same profile as the embedded run (without --profile a real bus chooses from 1000h). The
# drive is the reference drive with nothing to lose: factory restores allowed, as on the
# simulated bus.
# Bounded (SIGINT: an interrupted run keeps and reports what it finished), so that a run too
# slow for the VM's time says how far it got instead of being cut off with nothing.
timeout -s INT "${SOCKETCAN_RUN_LIMIT:-700}" \
  drivecheck run --bus socketcan:vcan0 --node 1 --profile cia402-reference --allow-motion \
  --allow-factory-restore \
  --filter "$filter" \
  --json "$out/socketcan.json" --trace "$out/socketcan.log" > "$out/socketcan.txt" 2>&1
socketcan_status=$?
kill "$drive" 2>/dev/null
wait "$drive" 2>/dev/null

drivecheck run --bus sim --node 1 --filter "$filter" --json "$out/sim.json" > "$out/sim.txt" 2>&1
sim_status=$?

# Every verdict of the SocketCAN run other than pass and n/a (failures, warnings, deviations,
# harness errors, interruptions), then its summary.
grep -E "^(× |x |! |~ |E |\? )" "$out/socketcan.txt"
tail -1 "$out/socketcan.txt"
tail -1 "$out/sim.txt"
echo "conformance_in_vm: socketcan run exit $socketcan_status, embedded run exit $sim_status"
# Vectors the harness could not judge at first (it stalled: a busy host) and ran again.
echo "conformance_in_vm: vectors run again after the harness was late:" \
  "$(grep -o 'times, the harness was late in the first' "$out/socketcan.json" | wc -l)"
drivecheck report diff "$out/sim.json" "$out/socketcan.json" > "$out/diff.txt" 2>&1
diff_status=$?
cat "$out/diff.txt"
# The expected differences: vectors that need simulated inputs (faults, switches) or the DUT's
# CAN controller on the simulated bus (bus_off) are not applicable on a real bus. Every other
# change is a difference.
grep -E "^(new failure|fixed|changed|added|removed)" "$out/diff.txt" |
  grep -v -e "-> not-applicable: requires simulation" \
    -e "-> not-applicable: the bus_off step needs the DUT's CAN controller on the simulated bus" \
    > "$out/unexpected.txt"
if [ "$socketcan_status" != "$sim_status" ] || [ "$diff_status" != 0 ] ||
  [ -s "$out/unexpected.txt" ]; then
  cat "$out/unexpected.txt"
  # What the SocketCAN run said about each of them (the whole message, not its first line).
  for id in $(cut -c14- "$out/unexpected.txt" | awk '{ print $1 }'); do
    grep -F -A3 -- " $id " "$out/socketcan.txt" | head -8
  done
  echo "conformance_in_vm: FAILED: the SocketCAN run differs from the embedded run"
  exit 1
fi
if [ "$sim_status" != 0 ]; then
  echo "conformance_in_vm: FAILED: vectors fail against the reference drive"
  exit 1
fi
echo "conformance_in_vm: the SocketCAN and embedded runs agree"
