#!/usr/bin/python3
"""Read a JUnit XML report with junitparser and print a JSON summary of it.

    check_junit.py REPORT.xml     # exits 1 when the file cannot be parsed as JUnit XML
    check_junit.py --self-test

Needs Debian's python3-junitparser (apt-get install python3-junitparser), which installs for the
system interpreter /usr/bin/python3. The root may be <testsuites> or a single <testsuite>. Counts are
taken from the test cases themselves; when a suite's own tests/failures/errors/skipped attributes
disagree with them, a warning goes to stderr. Output:

  {"suites": [{"name": .., "tests": N, "failures": N, "errors": N, "skipped": N,
               "cases": [{"name": .., "classname": .., "result": "passed|failure|error|skipped",
                          "message": ..}]}]}
"""
import json
import os
import shutil
import sys
import tempfile

try:
    import junitparser
except ImportError:  # another interpreter than Debian's: try the Debian package's folder
    sys.path.append("/usr/lib/python3/dist-packages")
    try:
        import junitparser
    except ImportError:
        sys.exit("check_junit: needs python3-junitparser (apt-get install python3-junitparser)")

# Worst first: a case with an error and a failure counts as an error.
RESULTS = (("error", junitparser.Error), ("failure", junitparser.Failure), ("skipped", junitparser.Skipped))
COUNTS = ("tests", "failures", "errors", "skipped")


def case_summary(case):
    found = case.result
    for result, kind in RESULTS:
        entries = [r for r in found if isinstance(r, kind)]
        if entries:
            text = entries[0].message or (entries[0].text or "").strip() or None
            return {"name": case.name, "classname": case.classname, "result": result, "message": text}
    return {"name": case.name, "classname": case.classname, "result": "passed", "message": None}


def summarize(path):
    xml = junitparser.JUnitXml.fromfile(path)
    suites = [xml] if isinstance(xml, junitparser.TestSuite) else list(xml)
    out = []
    for suite in suites:
        cases = [case_summary(case) for case in suite]
        counted = {"tests": len(cases),
                   "failures": sum(c["result"] == "failure" for c in cases),
                   "errors": sum(c["result"] == "error" for c in cases),
                   "skipped": sum(c["result"] == "skipped" for c in cases)}
        for key in COUNTS:
            declared = suite._elem.get(key)
            if declared is not None and declared.strip() != str(counted[key]):
                print("check_junit: %s: suite %r declares %s=%s but has %d"
                      % (path, suite.name, key, declared, counted[key]), file=sys.stderr)
        out.append(dict({"name": suite.name}, **counted, cases=cases))
    return {"suites": out}


GOOD = """<?xml version="1.0" encoding="UTF-8"?>
<testsuites tests="4" failures="1" errors="1" skipped="1">
  <testsuite name="hazards" tests="4" failures="1" errors="1" skipped="1">
    <testcase name="cut_in_0001" classname="hazardforge.cut_in" time="1.5"/>
    <testcase name="cut_in_0002" classname="hazardforge.cut_in">
      <failure message="no warning before 2.0 s TTC" type="late_warning">frame 31</failure>
    </testcase>
    <testcase name="jaywalker_0001" classname="hazardforge.jaywalker">
      <error message="program exited with status 2 at frame 4"/>
    </testcase>
    <testcase name="oncoming_0001" classname="hazardforge.oncoming"><skipped/></testcase>
  </testsuite>
</testsuites>
"""
SINGLE = """<testsuite name="one" tests="1"><testcase name="a" classname="k"/></testsuite>"""


def self_test():
    root = tempfile.mkdtemp(prefix="junit_selftest_")
    try:
        def write(name, text):
            path = os.path.join(root, name)
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
            return path
        summary = summarize(write("good.xml", GOOD))
        suite = summary["suites"][0]
        assert [suite[k] for k in COUNTS] == [4, 1, 1, 1], suite
        assert [c["result"] for c in suite["cases"]] == ["passed", "failure", "error", "skipped"], suite
        assert suite["cases"][1]["message"] == "no warning before 2.0 s TTC", suite
        assert suite["cases"][0]["classname"] == "hazardforge.cut_in", suite
        single = summarize(write("single.xml", SINGLE))["suites"]
        assert len(single) == 1 and single[0]["name"] == "one" and single[0]["tests"] == 1, single
        broken = (("cut.xml", GOOD[:-30]), ("html.xml", "<html><body/></html>"), ("empty.xml", ""))
        for name, text in broken:
            try:
                summarize(write(name, text))
            except Exception as error:  # what main() reports as unparseable
                print("self-test: rejected %s: %s" % (name, error), file=sys.stderr)
            else:
                raise AssertionError("parsed a broken report: " + name)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    print("self-test passed")
    return 0


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    if argv[1] == "--self-test":
        return self_test()
    try:
        summary = summarize(argv[1])
    except Exception as error:  # unreadable file, not XML, or a root that is not JUnit
        print("check_junit: cannot parse %s: %s" % (argv[1], error), file=sys.stderr)
        return 1
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
