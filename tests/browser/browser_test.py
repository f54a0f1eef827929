#!/usr/bin/env python3
"""The HTML report in a real browser (headless Chromium), CTest label `browser`.

    browser_test.py --generator make_browser_report --out DIR [--from RUN.json] [--many N]

1. make_browser_report writes DIR/report.html and DIR/report.json (the synthetic run, a real
   run's JSON given with --from, or N generated vectors with --many).
2. Chromium loads report.html#open=<id of a failing vector> and dumps the DOM after the page's
   script ran (--dump-dom). Checked: the script ran (<body data-js="ready">); every count shown
   (data-count-*) equals the JSON's; one <details class="vector"> per vector with the JSON's
   verdicts; the failing vector is open (opened by the fragment) and its transcript shows each
   of its frames.
3. Chromium loads report.html#filter=fail: exactly the failing vectors are left visible; and
   #filter=all&family=<its family> (a matrix cell's link): exactly that family's vectors.
4. Chromium takes a screenshot of the opened failing vector: DIR/report.png, a non-empty PNG.

Exit 0 pass, 1 fail, 77 skipped (no Chromium installed; CTest SKIP_RETURN_CODE).
"""
import argparse
import html.parser
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.parse

SKIP = 77
VERDICTS = ["pass", "fail", "deviation", "not-applicable", "error"]


def find_chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def run_chromium(chromium, profile, url, *extra):
    command = [chromium, "--headless=new", "--no-sandbox", "--disable-gpu",
               "--disable-dev-shm-usage", "--no-first-run", "--disable-extensions",
               "--user-data-dir=" + profile, "--virtual-time-budget=5000", *extra, url]
    started = time.monotonic()
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=180,
                          check=False)
    elapsed = time.monotonic() - started
    if done.returncode != 0:
        raise AssertionError(f"chromium exited {done.returncode}: "
                             f"{done.stderr.decode(errors='replace')[-2000:]}")
    return done.stdout.decode("utf-8", errors="replace"), elapsed


class Dom(html.parser.HTMLParser):
    """What the test needs from the dumped DOM."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.body = {}
        self.counts = {}          # data-count-<name> -> shown text
        self.vectors = []         # attribute dicts of <details class="vector">
        self.transcripts = {}     # vector id -> transcript text
        self._count = None
        self._vector = None
        self._in_transcript = False

    def handle_starttag(self, tag, attrs):
        attributes = dict(attrs)
        if tag == "body":
            self.body = attributes
        for name in attributes:
            if name.startswith("data-count-"):
                self._count = name[len("data-count-"):]
                self.counts[self._count] = ""
        if tag == "details" and "vector" in (attributes.get("class") or "").split():
            self.vectors.append(attributes)
            self._vector = attributes.get("id", "")[2:]
        if tag == "pre" and "transcript" in (attributes.get("class") or "").split():
            self._in_transcript = True
            self.transcripts[self._vector] = ""

    def handle_endtag(self, tag):
        if tag == "pre":
            self._in_transcript = False
        if tag == "b":
            self._count = None

    def handle_data(self, data):
        if self._count is not None:
            self.counts[self._count] += data
        if self._in_transcript:
            self.transcripts[self._vector] += data


def check(condition, message, failures):
    if not condition:
        failures.append(message)
        print("FAIL:", message)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--generator", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--from", dest="from_json")
    parser.add_argument("--many", type=int)
    args = parser.parse_args()

    chromium = find_chromium()
    if chromium is None:
        print("SKIP: Chromium is not installed (Debian: apt-get install chromium)")
        return SKIP

    out = pathlib.Path(args.out).resolve()
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    generator = [args.generator, str(out)]
    if args.from_json:
        generator += ["--from", args.from_json]
    elif args.many:
        generator += ["--many", str(args.many)]
    subprocess.run(generator, check=True)
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    page = (out / "report.html").as_uri()

    vectors = report["vectors"]
    failing = [v for v in vectors if v["verdict"] == "fail" and not v["warning"]]
    failing += [v for v in vectors if v["verdict"] == "error"]
    if not failing:
        print("FAIL: the run has no failing vector to open")
        return 1
    target = failing[0]
    failures = []
    with tempfile.TemporaryDirectory(prefix="drivecheck-chromium-") as profile:
        # 2. counts, vectors, the fragment opens the failing vector
        fragment = "#open=" + urllib.parse.quote(target["id"], safe="")
        text, elapsed = run_chromium(chromium, profile, page + fragment, "--dump-dom")
        print(f"loaded {len(vectors)} vectors ({(out / 'report.html').stat().st_size} bytes) "
              f"and dumped the DOM in {elapsed:.2f} s")
        dom = Dom()
        dom.feed(text)
        check(dom.body.get("data-js") == "ready", "the page's script did not run", failures)
        expected = {name: report["counts"][name] for name in VERDICTS}
        expected["total"] = report["counts"]["total"]
        expected["warnings"] = report["counts"]["warnings"]
        for name, value in expected.items():
            shown = dom.counts.get(name, "").strip()
            check(shown == str(value), f"count {name}: shown {shown!r}, JSON {value}", failures)
        check(len(dom.vectors) == len(vectors),
              f"{len(dom.vectors)} vectors shown, JSON has {len(vectors)}", failures)
        for name in VERDICTS:
            shown = sum(1 for v in dom.vectors if v.get("data-verdict") == name)
            check(shown == report["counts"][name],
                  f"{shown} vectors with data-verdict={name}, JSON {report['counts'][name]}",
                  failures)
        opened = [v for v in dom.vectors if "open" in v]
        check([v.get("id") for v in opened] == ["v:" + target["id"]],
              f"open vectors {[v.get('id') for v in opened]}, expected only {target['id']}",
              failures)
        check(bool(opened) and opened[0].get("data-opened") == "fragment",
              "the failing vector was not opened by the URL fragment", failures)
        transcript = dom.transcripts.get(target["id"], "")
        for frame in target["frames"]:
            check(frame["frame"] in transcript,
                  f"transcript of {target['id']} lacks {frame['frame']}", failures)
        if target["frames"]:
            print(f"opened {target['id']}: transcript starts "
                  f"{transcript.splitlines()[0] if transcript else '(empty)'!r}")

        # 3. the verdict filter leaves exactly the failing vectors visible
        text, _ = run_chromium(chromium, profile, page + "#filter=fail", "--dump-dom")
        dom = Dom()
        dom.feed(text)
        visible = [v for v in dom.vectors if "hidden" not in v]
        check(len(visible) == report["counts"]["fail"] and
              all(v.get("data-verdict") == "fail" for v in visible),
              f"#filter=fail left {len(visible)} vectors visible "
              f"({sorted(set(v.get('data-verdict') for v in visible))}), "
              f"JSON has {report['counts']['fail']} failures", failures)

        # 3b. a matrix cell: every vector of the failing vector's family, nothing else
        family = target["family"]
        in_family = sum(1 for v in vectors if v["family"] == family)
        text, _ = run_chromium(chromium, profile,
                               page + "#filter=all&family=" + urllib.parse.quote(family, safe=""),
                               "--dump-dom")
        dom = Dom()
        dom.feed(text)
        visible = [v for v in dom.vectors if "hidden" not in v]
        check(len(visible) == in_family and all(v.get("data-family") == family for v in visible),
              f"#filter=all&family={family} left {len(visible)} vectors visible, "
              f"JSON has {in_family} in that family", failures)

        # 4. screenshot of the opened failing vector
        png = out / "report.png"
        run_chromium(chromium, profile, page + fragment, "--screenshot=" + str(png),
                     "--window-size=1280,1600", "--hide-scrollbars")
        data = png.read_bytes() if png.exists() else b""
        check(len(data) > 1000 and data[:8] == b"\x89PNG\r\n\x1a\n",
              f"screenshot {png}: {len(data)} bytes, not a PNG", failures)
        print(f"screenshot {png} ({len(data)} bytes)")

    if failures:
        print(f"{len(failures)} browser checks failed")
        return 1
    print("browser checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
