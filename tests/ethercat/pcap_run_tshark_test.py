#!/usr/bin/env python3
"""CTest ethercat.pcap-tshark: `drivecheck run --bus ethercat:sim --pcap F` on a few CoE
vectors, then Wireshark's engine (tshark) and `drivecheck decode F` read F.

Checks (each failure says what and exits 1; exit 77 = skipped, only when tshark is absent):
  - the run passes (exit 0) and writes the pcap, the JSON report validates against
    reports/report.schema.json and holds the vectors' datagrams with CoE SDO lines;
  - tshark decodes every frame as EtherCAT (ecat.cmd), the mailbox header (ecat_mailbox.type,
    .counter) and CoE SDO with index and sub-index (ecat_mailbox.coe.sdoidx/.sdosub) for the
    objects the vectors read and wrote (1000h:00, 1018h:01), and the server's abort (scs 4);
  - `drivecheck decode F` reads as many frames and datagrams as tshark, and names the same
    SDO index:sub pairs in the mailboxes as tshark does, and sees the
    SDO aborts in the same frames.
"""
import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

VECTORS = ["cia301/od/mandatory/device-type", "cia301/sdo/abort/write-identity"]


def fail(message):
    print(f"FAIL: {message}")
    sys.exit(1)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--drivecheck", required=True)
    parser.add_argument("--schema", required=True)
    args = parser.parse_args()
    tshark = shutil.which("tshark")
    if tshark is None:
        print("SKIPPED: tshark is not installed (scripts/bootstrap installs it; apt-get install "
              "tshark)")
        sys.exit(77)
    with tempfile.TemporaryDirectory(prefix="drivecheck-ecat-pcap-") as tmp:
        tmp = Path(tmp)
        pcap = tmp / "run.pcap"
        report = tmp / "report.json"
        command = [args.drivecheck, "run", "--bus", "ethercat:sim", "--pcap", str(pcap),
                   "--json", str(report), "--color", "never"]
        for vector in VECTORS:
            command += ["--filter", vector]
        run = subprocess.run(command, cwd=tmp, capture_output=True, text=True, timeout=300)
        if run.returncode != 0:
            fail(f"drivecheck run exited {run.returncode}:\n{run.stdout}\n{run.stderr}")
        if not pcap.exists() or pcap.stat().st_size <= 24:
            fail("the run wrote no pcap records")

        # The JSON report: valid, with each vector's datagrams decoded.
        data = json.loads(report.read_text())
        try:
            import jsonschema
            jsonschema.validate(data, json.loads(Path(args.schema).read_text()))
        except ImportError:
            fail("python3-jsonschema is missing (scripts/bootstrap installs it)")
        except jsonschema.ValidationError as error:
            fail(f"report.json does not match the schema: {error.message} at "
                 f"{list(error.absolute_path)}")
        by_id = {v["id"]: v for v in data["vectors"]}
        for vector in VECTORS:
            v = by_id.get(vector)
            if v is None or v["verdict"] != "pass":
                fail(f"{vector}: not passed in the report ({v and v['verdict']})")
            lines = [d["decoded"] for d in v.get("datagrams", [])]
            if not any("SDO" in line and "write mailbox" in line for line in lines):
                fail(f"{vector}: no SDO request in its datagrams:\n" + "\n".join(lines[:40]))
        identity = [d["decoded"] for d in by_id[VECTORS[1]]["datagrams"]]
        if not any("1018h:01" in line and "06010002h write_read_only" in line
                   for line in identity):
            fail("write-identity: the abort 06010002h is not named in its datagrams")

        # tshark: every frame EtherCAT, mailbox and CoE SDO decoded.
        fields = ["frame.number", "ecat.cmd", "ecat_mailbox.type", "ecat_mailbox.counter",
                  "ecat_mailbox.coe.type", "ecat_mailbox.coe.sdoidx", "ecat_mailbox.coe.sdosub",
                  "ecat_mailbox.coe.sdores"]
        out = subprocess.run([tshark, "-r", str(pcap), "-T", "fields", "-E", "separator=\t",
                              "-E", "occurrence=a", "-E", "aggregator=,"] +
                             sum([["-e", f] for f in fields], []),
                             capture_output=True, text=True, timeout=300)
        if out.returncode != 0:
            fail(f"tshark exited {out.returncode}: {out.stderr}")
        rows = [line.split("\t") for line in out.stdout.splitlines()]
        if not rows:
            fail("tshark read no frames")
        not_ecat = [r[0] for r in rows if not r[1]]
        if not_ecat:
            fail(f"tshark did not decode frames {not_ecat[:10]} as EtherCAT")
        tshark_datagrams = sum(len(r[1].split(",")) for r in rows)
        mailbox_rows = [r for r in rows if r[2]]
        if not mailbox_rows:
            fail("tshark decoded no mailbox")
        tshark_sdo = set()
        for r in rows:
            if r[5]:
                for idx, sub in zip(r[5].split(","), r[6].split(",")):
                    tshark_sdo.add((int(idx, 0), int(sub, 0)))
        for want in [(0x1000, 0), (0x1018, 1)]:
            if want not in tshark_sdo:
                fail(f"tshark shows no CoE SDO for {want[0]:04X}h:{want[1]:02X} "
                     f"(it shows {sorted(tshark_sdo)[:20]})")
        # SDO responses with scs 4 (abort transfer, CiA 301 §7.2.4.3.17): Wireshark 4.0 names
        # the server's abort by its command specifier (it prints no code for a response).
        tshark_aborts = {int(r[0]) for r in rows if "4" in r[7].split(",")}
        if not tshark_aborts:
            fail("tshark shows no SDO abort (scs 4) response")

        # drivecheck decode: the same frames and datagrams, the same SDO objects.
        dec = subprocess.run([args.drivecheck, "decode", str(pcap)], capture_output=True,
                             text=True, timeout=300)
        if dec.returncode != 0:
            fail(f"drivecheck decode exited {dec.returncode}: {dec.stderr}")
        summary = re.search(r"(\d+) EtherCAT frame\(s\), (\d+) datagram\(s\), (\d+) malformed",
                            dec.stderr)
        if summary is None:
            fail(f"drivecheck decode printed no summary: {dec.stderr}")
        frames, datagrams, malformed = map(int, summary.groups())
        if frames != len(rows):
            fail(f"drivecheck decode read {frames} frames, tshark {len(rows)}")
        if datagrams != tshark_datagrams:
            fail(f"drivecheck decode read {datagrams} datagrams, tshark {tshark_datagrams}")
        if malformed != 0:
            fail(f"drivecheck decode calls {malformed} frame(s) of our own run malformed")
        ours = set()
        our_aborts = set()
        for line in dec.stdout.splitlines():
            if "SDO abort by the server" in line:
                our_aborts.add(int(line.split()[1].lstrip("#")))
            if "mailbox" in line and "SDO" in line:
                for idx, sub in re.findall(r"SDO [a-z ]*?([0-9A-F]{4})h:([0-9A-F]{2})", line):
                    ours.add((int(idx, 16), int(sub, 16)))
        if not ours:
            fail("drivecheck decode shows no SDO in a mailbox")
        if not ours <= tshark_sdo:
            fail(f"drivecheck decode names SDO objects tshark does not: {sorted(ours - tshark_sdo)}")
        if our_aborts != tshark_aborts:
            fail(f"SDO aborts: drivecheck decode in frames {sorted(our_aborts)}, tshark in "
                 f"{sorted(tshark_aborts)}")
        print(f"ok: {frames} frames, {datagrams} datagrams; SDO objects "
              f"{[f'{i:04X}h:{s:02X}' for i, s in sorted(ours)]} decoded by "
              f"both; {len(mailbox_rows)} frames with a mailbox in tshark")


if __name__ == "__main__":
    main()
