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
5. In a DevTools session (--remote-debugging-pipe): typing into the search box leaves exactly
   the vectors whose id, title, sources or message contain the text; a link of the clause
   matrix leaves exactly the vectors citing that clause; with print media emulated, every
   failure, error and warning shows its transcript (expanded) and a passing vector does not,
   and printing to PDF works.

Exit 0 pass, 1 fail, 77 skipped (no Chromium installed; CTest SKIP_RETURN_CODE).
"""
import argparse
import base64
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
VERDICTS = ["pass", "fail", "deviation", "not-applicable", "error", "interrupted"]
TALLIES = ["pass", "fail", "warning", "deviation", "not-applicable", "error", "interrupted"]


def tally(vector):
    if vector["verdict"] == "fail":
        return "warning" if vector["warning"] else "fail"
    return vector["verdict"]


def clause_of(source):
    """reports::clause_of: "<document> §<section>" without lines or free text."""
    mark = source.find("§")
    if mark < 0:
        end = source.find(" L")
        return source if end < 0 else source[:end]
    end = mark + 1
    while end < len(source) and source[end] not in " ,;":
        end += 1
    return source[:mark].rstrip(" ") + " " + source[mark:end]


class DevTools:
    """A minimal Chrome DevTools Protocol client over --remote-debugging-pipe (fds 3 and 4)."""

    def __init__(self, chromium, profile, url):
        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()

        def child_fds():
            import fcntl  # pylint: disable=import-outside-toplevel
            read_end = fcntl.fcntl(to_chrome_r, fcntl.F_DUPFD, 10)
            write_end = fcntl.fcntl(from_chrome_w, fcntl.F_DUPFD, 10)
            os.dup2(read_end, 3)
            os.dup2(write_end, 4)

        self._process = subprocess.Popen(
            [chromium, "--headless=new", "--no-sandbox", "--disable-gpu",
             "--disable-dev-shm-usage", "--no-first-run", "--disable-extensions",
             "--user-data-dir=" + profile, "--remote-debugging-pipe", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=child_fds,
            pass_fds=(3, 4))
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self._buffer = b""
        self._next_id = 0
        self.session = None
        targets = self.call("Target.getTargets")["targetInfos"]
        page = next(t for t in targets if t["type"] == "page")
        self.session = self.call("Target.attachToTarget",
                                 {"targetId": page["targetId"], "flatten": True})["sessionId"]
        self.call("Page.enable")
        self.call("Page.navigate", {"url": url})
        deadline = time.monotonic() + 60
        while self.evaluate("document.body && document.body.getAttribute('data-js')") != "ready":
            if time.monotonic() > deadline:
                raise AssertionError("the page's script did not run within 60 s")
            time.sleep(0.1)

    def call(self, method, params=None):
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params or {}}
        if self.session and not method.startswith(("Target.", "Browser.")):
            message["sessionId"] = self.session
        os.write(self._to_chrome, json.dumps(message).encode() + b"\0")
        while True:
            while b"\0" not in self._buffer:
                chunk = os.read(self._from_chrome, 1 << 20)
                if not chunk:
                    raise AssertionError("chromium closed the DevTools pipe")
                self._buffer += chunk
            raw, self._buffer = self._buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise AssertionError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def evaluate(self, expression):
        result = self.call("Runtime.evaluate",
                           {"expression": expression, "returnByValue": True})
        if "exceptionDetails" in result:
            raise AssertionError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def close(self):
        try:
            self.call("Browser.close")
        except AssertionError:
            pass
        try:
            self._process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self._process.kill()
        os.close(self._to_chrome)
        os.close(self._from_chrome)


VISIBLE_IDS = ("Array.from(document.querySelectorAll('details.vector'))"
               ".filter(function (d) { return !d.hidden; })"
               ".map(function (d) { return d.id.slice(2); })")


def interactive_checks(chromium, profile, page, report, failures):
    """5. search, clause matrix, print expansion, in a DevTools session."""
    vectors = report["vectors"]
    session = DevTools(chromium, profile, page)
    try:
        # search: a word of a failing vector's title, typed into the box
        target = next(v for v in vectors if tally(v) in ("fail", "error"))
        term = target["id"].split("/")[-1]
        session.evaluate("var s = document.getElementById('search'); s.focus(); s.value = "
                         + json.dumps(term) + "; s.dispatchEvent(new Event('input'));")
        shown = session.evaluate(VISIBLE_IDS)
        expected = [v["id"] for v in vectors
                    if term.lower() in " ".join([v["id"], v["title"], v["message"],
                                                 *v["sources"]]).lower()]
        check(set(shown) == set(expected) and target["id"] in shown,
              f"search {term!r}: {len(shown)} shown, expected {len(expected)} "
              f"({sorted(set(shown) ^ set(expected))[:5]} differ)", failures)
        print(f"search {term!r}: {len(shown)} of {len(vectors)} vectors shown")
        session.evaluate("var s = document.getElementById('search'); s.value = ''; "
                         "s.dispatchEvent(new Event('input'));")

        # clause matrix: open it, click the first clause's link
        clauses = session.evaluate(
            "document.getElementById('clause-box').open = true;"
            "Array.from(document.querySelectorAll('#clause-matrix a[data-clause-link]'))"
            ".map(function (a) { return a.getAttribute('data-clause-link'); })")
        expected_clauses = sorted({clause_of(s) for v in vectors for s in v["sources"]})
        check(sorted(clauses) == expected_clauses,
              f"clause matrix rows {len(clauses)}, JSON cites {len(expected_clauses)} clauses",
              failures)
        if clauses:
            clause = min(clauses, key=lambda c: sum(
                1 for v in vectors if c in {clause_of(s) for s in v["sources"]}))
            session.evaluate("document.querySelector('#clause-matrix a[data-clause-link=' + "
                             "JSON.stringify(" + json.dumps(clause) + ") + ']').click()")
            time.sleep(0.2)
            shown = session.evaluate(VISIBLE_IDS)
            citing = [v["id"] for v in vectors if clause in {clause_of(s) for s in v["sources"]}]
            check(sorted(shown) == sorted(citing),
                  f"clause {clause!r}: {len(shown)} shown, {len(citing)} vectors cite it",
                  failures)
            print(f"clause {clause!r}: {len(shown)} vectors shown")
            session.evaluate("location.hash = 'filter=all'")
            time.sleep(0.2)

        # print: failures, errors and warnings expanded with their evidence, passes not
        session.call("Emulation.setEmulatedMedia", {"media": "print"})
        visible = session.evaluate(
            "Array.from(document.querySelectorAll('details.vector')).map(function (d) {"
            " var t = d.querySelector('pre.transcript:not(.between-vectors)');"
            " return [d.id.slice(2), !!t && t.checkVisibility()]; })")
        visible = dict(visible)
        for vector in vectors:
            expand = tally(vector) in ("fail", "error", "warning")
            if expand:
                check(visible.get(vector["id"]),
                      f"print: {vector['id']} ({tally(vector)}) is not expanded", failures)
        passing = [v["id"] for v in vectors if tally(v) == "pass"]
        if passing:
            check(not visible.get(passing[0]), f"print: passing {passing[0]} is expanded",
                  failures)
        session.call("Emulation.setEmulatedMedia", {"media": ""})
        pdf = session.call("Page.printToPDF", {})
        data = base64.b64decode(pdf.get("data", ""))
        check(data[:5] == b"%PDF-", f"printToPDF gave {len(data)} bytes, not a PDF", failures)
        print(f"print: {sum(1 for v in vectors if tally(v) in ('fail', 'error', 'warning'))} "
              f"vectors expanded, PDF {len(data)} bytes")
    finally:
        session.close()


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
    failing = [v for v in vectors if tally(v) == "fail"]
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
        expected = {name: report["counts"][name] for name in TALLIES}
        expected["total"] = report["counts"]["total"]
        for name, value in expected.items():
            shown = dom.counts.get(name, "").strip()
            check(shown == str(value), f"count {name}: shown {shown!r}, JSON {value}", failures)
        check(len(dom.vectors) == len(vectors),
              f"{len(dom.vectors)} vectors shown, JSON has {len(vectors)}", failures)
        for name in TALLIES:
            shown = sum(1 for v in dom.vectors if v.get("data-tally") == name)
            check(shown == report["counts"][name],
                  f"{shown} vectors with data-tally={name}, JSON {report['counts'][name]}",
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
              all(v.get("data-tally") == "fail" for v in visible),
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

    with tempfile.TemporaryDirectory(prefix="drivecheck-chromium-") as profile:
        interactive_checks(chromium, profile, page, report, failures)

    if failures:
        print(f"{len(failures)} browser checks failed")
        return 1
    print("browser checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
