#!/usr/bin/env python3
"""The reports of a run as the tools that read them see them (CTest `reports.run.*`).

    check_reports.py --schema reports/report.schema.json --xsd tests/reports/junit.xsd
                     --drivecheck EXE --out DIR [--expect-exit N] [-- run arguments...]
    check_reports.py --schema ... --json FILE...          (validate JSON reports only)

With --drivecheck: runs `drivecheck run <arguments> --json/--junit/--html` into DIR, keeps the
console output, then checks
1. the JSON report validates against the JSON Schema (python3-jsonschema, Draft 2020-12);
2. the JUnit report validates against the XSD (xmllint), and its DUT identity is given once;
3. the counts agree in all four outputs (console summary, JUnit, HTML, JSON) and with a recount
   of the JSON's vectors by one rule (a should/may failure without --strict is a warning;
   interrupted and not-applicable vectors are skipped in JUnit);
4. every failure's message (console line, JUnit message attribute, JSON message's first line)
   is one line "<file>:<line>: step N <action>: Expected ...; Actual ...", N numbers the step
   as the JSON's checks do (from 1), and the file:line is the vector's file;
5. every report carries the revision and the vector-set digest, and the documents the
   citations refer to;
6. with --expect-esi FILE (a run with --esi FILE): every report names the ESI with its sha256,
   and the ESI device's identity once (JSON run.esi, JUnit esi.*, HTML rows, console header).

Exit 0 pass, 1 fail, 77 skipped (python3-jsonschema or xmllint missing; CTest SKIP_RETURN_CODE).
"""
import argparse
import hashlib
import html.parser
import json
import pathlib
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

SKIP = 77
TALLIES = ["pass", "fail", "warning", "deviation", "not-applicable", "error", "interrupted"]


def tally(vector):
    if vector["verdict"] == "fail":
        return "warning" if vector["warning"] else "fail"
    return vector["verdict"]


def validate_json(schema_path, path, failures):
    import jsonschema  # pylint: disable=import-outside-toplevel
    schema = json.loads(pathlib.Path(schema_path).read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    document = json.loads(pathlib.Path(path).read_text(encoding="utf-8"))
    errors = list(jsonschema.Draft202012Validator(schema).iter_errors(document))
    for error in errors[:10]:
        failures.append(f"{path}: {error.json_path}: {error.message[:300]}")
    if not errors:
        print(f"{path}: valid against {schema_path}")
    return document


class HtmlCounts(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.counts = {}
        self._name = None

    def handle_starttag(self, tag, attrs):
        for name, _ in attrs:
            if name.startswith("data-count-"):
                self._name = name[len("data-count-"):]
                self.counts[self._name] = ""

    def handle_endtag(self, tag):
        self._name = None

    def handle_data(self, data):
        if self._name:
            self.counts[self._name] += data


ONE_LINE = re.compile(r"^(?P<file>[^:\n]+):(?P<line>\d+): step (?P<step>\d+) (?P<action>\S+): "
                      r"Expected .+; Actual .+$")


def check_message(where, message, vector, failures):
    match = ONE_LINE.match(message)
    if not match:
        failures.append(f"{where}: not a one-line '<file>:<line>: step N action: Expected ...; "
                        f"Actual ...' message: {message[:200]!r}")
        return
    if match["file"] != vector["file"]:
        failures.append(f"{where}: names {match['file']}, the vector is in {vector['file']}")
    step = int(match["step"])
    failed_steps = [c["step"] for c in vector["checks"] if not c["ok"]]
    if step not in failed_steps:
        failures.append(f"{where}: says step {step}, the JSON's failed checks are steps "
                        f"{failed_steps}")


def check_esi(path, run, junit_root, page, console, failures):
    """run.esi (JSON), esi.* properties (JUnit), the ESI rows (HTML) and the console header
    all give the ESI's file and its sha256, and the ESI device's identity once."""
    digest = hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()
    esi = run.get("esi")
    if esi is None:
        failures.append("JSON run.esi is missing")
        return
    if esi.get("file") != path or esi.get("sha256") != digest:
        failures.append(f"JSON run.esi {esi.get('file')!r} {esi.get('sha256')!r}, expected "
                        f"{path!r} {digest}")
    device = esi.get("device")
    if not device or not device.get("name"):
        failures.append(f"JSON run.esi.device {device!r}: no device identity")
        device = {}
    props = {}
    for prop in junit_root.iter("property"):
        props.setdefault(prop.get("name"), []).append(prop.get("value"))
    for key, want in (("esi.file", path), ("esi.sha256", digest),
                      ("esi.product_code", f"0x{device.get('product_code', 0):08X}"),
                      ("esi.name", device.get("name"))):
        if props.get(key) != [want]:
            failures.append(f"junit.xml: property {key} {props.get(key)!r}, expected [{want!r}]")
    if f"{html.escape(path)}  sha256 {digest}" not in page or "<dt>ESI device</dt>" not in page:
        failures.append("report.html lacks the ESI row with its sha256 or the ESI device row")
    header = [line for line in console.splitlines() if line.startswith(f"drivecheck run: ESI {path}")]
    if len(header) != 1 or digest not in header[0] or \
            f"product code {device.get('product_code', 0):08X}h" not in header[0]:
        failures.append(f"console: the ESI header line {header!r} lacks the sha256 or identity")
    print(f"ESI {path}: sha256 {digest}, device {device.get('name')!r} in every report")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--schema", required=True)
    parser.add_argument("--xsd")
    parser.add_argument("--drivecheck")
    parser.add_argument("--out")
    parser.add_argument("--expect-exit", type=int, default=0)
    parser.add_argument("--json", nargs="*", default=[])
    parser.add_argument("--expect-observed", metavar="KEY",
                        help="every failed sdo_read/sdo_write check of a failed vector carries "
                             "observed.KEY (the typed observation, e.g. abort)")
    parser.add_argument("--expect-esi", metavar="FILE",
                        help="the run had --esi FILE: every report names it with its sha256 "
                             "and the ESI device's identity, once")
    parser.add_argument("run_args", nargs="*")
    args = parser.parse_args()

    try:
        import jsonschema  # noqa: F401  pylint: disable=import-outside-toplevel,unused-import
    except ImportError:
        print("SKIP: python3-jsonschema is not installed (scripts/bootstrap installs it)")
        return SKIP
    failures = []
    for path in args.json:
        validate_json(args.schema, path, failures)
    if not args.drivecheck:
        for failure in failures:
            print("FAIL:", failure)
        return 1 if failures else 0
    if shutil.which("xmllint") is None:
        print("SKIP: xmllint is not installed (libxml2-utils)")
        return SKIP

    out = pathlib.Path(args.out)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    command = [args.drivecheck, "run", *args.run_args, "--json", str(out / "report.json"),
               "--junit", str(out / "junit.xml"), "--html", str(out / "report.html")]
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=600,
                          check=False, env={"LANG": "C.UTF-8", "PATH": "/usr/bin:/bin"})
    console = done.stdout.decode("utf-8", errors="replace")
    (out / "console.txt").write_text(console, encoding="utf-8")
    if done.returncode != args.expect_exit:
        print(console[-3000:], done.stderr.decode(errors="replace")[-3000:])
        print(f"FAIL: drivecheck exited {done.returncode}, expected {args.expect_exit}")
        return 1
    for name in ("report.json", "junit.xml", "report.html"):
        print(f"{name}: {(out / name).stat().st_size} bytes")

    # 1. JSON Schema.
    report = validate_json(args.schema, out / "report.json", failures)
    vectors = report["vectors"]
    recount = {name: 0 for name in TALLIES}
    for vector in vectors:
        recount[tally(vector)] += 1
    recount["total"] = len(vectors)

    # 2. JUnit XSD, identity once.
    lint = subprocess.run(["xmllint", "--noout", "--schema", args.xsd, str(out / "junit.xml")],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, check=False)
    if lint.returncode != 0:
        failures.append("junit.xml is not valid against the XSD: " +
                        lint.stderr.decode(errors="replace")[-1500:])
    root = ET.parse(out / "junit.xml").getroot()
    names = [p.get("name") for p in root.iter("property")]
    for key in ("dut.device_name", "dut.vendor_id", "profile", "revision", "vector_set.sha256"):
        if names.count(key) != 1:
            failures.append(f"junit.xml: property {key} appears {names.count(key)} times, "
                            f"expected once per file")

    # 3. Counts in every output.
    json_counts = {k: report["counts"].get(k) for k in TALLIES + ["total"]}
    if json_counts != recount:
        failures.append(f"JSON counts {json_counts} != recount of its vectors {recount}")
    junit = {"tests": int(root.get("tests")), "failures": int(root.get("failures")),
             "errors": int(root.get("errors")),
             "skipped": sum(int(s.get("skipped", "0")) for s in root.iter("testsuite"))}
    expected_junit = {"tests": recount["total"], "failures": recount["fail"],
                      "errors": recount["error"],
                      "skipped": recount["not-applicable"] + recount["interrupted"]}
    if junit != expected_junit:
        failures.append(f"JUnit counts {junit} != {expected_junit}")
    html_counts = HtmlCounts()
    html_counts.feed((out / "report.html").read_text(encoding="utf-8"))
    shown = {k: int(v) for k, v in html_counts.counts.items() if k in TALLIES + ["total"]}
    if shown != recount:
        failures.append(f"HTML counts {shown} != {recount}")
    summary = console.strip().splitlines()[-1]
    words = {"passed": "pass", "failed": "fail", "warnings": "warning",
             "deviations": "deviation", "not applicable": "not-applicable", "errors": "error",
             "interrupted": "interrupted"}
    console_counts = {"total": int(summary.split(" vectors:")[0])}
    console_counts["interrupted"] = 0
    for number, word in re.findall(r"(\d+) (passed|failed|warnings|deviations|not applicable|"
                                   r"errors|interrupted)", summary):
        console_counts[words[word]] = int(number)
    if console_counts != recount:
        failures.append(f"console counts {console_counts} (from {summary!r}) != {recount}")
    print(f"counts (JSON, JUnit, HTML, console agree unless said): {recount}")

    # 4. One-line failure messages with file:line and one step numbering.
    by_id = {v["id"]: v for v in vectors}
    for vector in vectors:
        if tally(vector) != "fail":
            continue
        first = vector["message"].split("\n", 1)[0]
        check_message(f"JSON {vector['id']}", first, vector, failures)
    for case in root.iter("testcase"):
        failure = case.find("failure")
        if failure is not None:
            check_message(f"JUnit {case.get('name')}", failure.get("message"),
                          by_id[case.get("name")], failures)
    for line in console.splitlines():
        if line.startswith("× ") or line.startswith("x "):
            vector_id, _, message = line[2:].partition(" — ")
            if vector_id in by_id:
                check_message(f"console {vector_id}", message, by_id[vector_id], failures)

    # 4b. Typed observations of failed checks (checks[].observed).
    if args.expect_observed:
        seen = 0
        for vector in vectors:
            if tally(vector) not in ("fail", "warning"):
                continue
            for check in vector["checks"]:
                if check["ok"] or check["action"] not in ("sdo_read", "sdo_write"):
                    continue
                seen += 1
                if args.expect_observed not in check.get("observed", {}):
                    failures.append(f"JSON {vector['id']} step {check['step']}: failed "
                                    f"{check['action']} without observed.{args.expect_observed}")
        if seen == 0:
            failures.append("no failed sdo_read/sdo_write check to carry an observation")
        print(f"failed SDO checks with observed.{args.expect_observed}: {seen}")

    # 5. Provenance.
    run = report["run"]
    vector_set = run.get("vector_set", {"sha256": "", "files": 0})
    if not re.fullmatch(r"[0-9a-f]{64}", vector_set["sha256"]) or vector_set["files"] == 0:
        failures.append(f"JSON run.vector_set {vector_set}")
    if not run.get("revision"):
        failures.append("JSON run.revision is missing or empty")
    keys = [d["key"] for d in run.get("documents", [])]
    for vector in vectors:
        for source in vector["sources"]:
            if not any(source.startswith(key) for key in keys) and \
                    not source.startswith(("EDS", "ESI")):
                failures.append(f"{vector['id']}: citation {source!r} names no listed document")
                break
    page = (out / "report.html").read_text(encoding="utf-8")
    for needle in (vector_set["sha256"] or "sha256 of the vector set", "v4.2.0",
                   'id="clause-matrix"'):
        if needle not in page:
            failures.append(f"report.html lacks {needle!r}")

    # 6. The ESI of a run with --esi: file and sha256 in every report, the device once.
    if args.expect_esi:
        check_esi(args.expect_esi, run, root, page, console, failures)

    for failure in failures:
        print("FAIL:", failure)
    if failures:
        print(f"{len(failures)} report checks failed")
        return 1
    print("report checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
