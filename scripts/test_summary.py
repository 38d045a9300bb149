#!/usr/bin/python3
"""Summarise the JUnit XML results of a catkin package's gtests and rostests.

    test_summary.py RESULTS_DIR [--ctest-file BUILD/cloth_sim/CTestTestfile.cmake]

Counts test cases in every *.xml under RESULTS_DIR (catkin_make run_tests writes them to
build/test_results/<package>/):
  gtest-*.xml      one case per gtest TEST of a catkin_add_gtest executable
  rosunit-*.xml    one case per gtest TEST (or unittest method) run inside a rostest
  rostest-*.xml    one case per <test> of a .test file: fails when the test node crashed, timed out or wrote
                   no results (rostest's own verdict)
  MISSING-*.xml    catkin's placeholder when a test wrote no result file at all: a failure
With --ctest-file, every result file the registered tests promise must exist, else that test counts as
one failed case (a test killed before catkin could write its placeholder).

Prints each failing case, then as its very last line "N passed, N failed". Exit status 0 only when
something ran and nothing failed.
"""
import argparse
import glob
import os
import re
import sys
import xml.etree.ElementTree as ET


def first_lines(text, limit=200):
    """The start of a failure message on one line (gtest puts file:line first, the expectation next)."""
    parts = [part.strip() for part in (text or "").splitlines() if part.strip()]
    if any(p.startswith('File "') for p in parts[1:]):
        parts = parts[:1]  # a Python assertion: its message comes first, the stack after it
    line = " | ".join(parts)
    return line if len(line) <= limit else line[:limit - 3] + "..."


def cases_of(path):
    """[(name, failed, reason)] for one result file; an unreadable file is one failed case."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        return [(os.path.basename(path), True, "unreadable result file: %s" % e)]
    out = []
    for case in root.iter("testcase"):
        name = case.get("name", "?")
        cls = case.get("classname", "")
        full = "%s.%s" % (cls, name) if cls and not name.startswith(cls) else name
        if case.get("status") == "notrun" or case.find("skipped") is not None:
            continue  # DISABLED_ gtests and skips are neither passes nor failures
        bad = [c for c in case if c.tag in ("failure", "error")]
        if bad:
            text = bad[0].get("message") or bad[0].text or bad[0].tag
            out.append((full, True, first_lines(text)))
        else:
            out.append((full, False, ""))
    if not out:
        # A suite-level error with no cases (e.g. a gtest binary that aborted mid-way and left a stub).
        errors = int(root.get("errors", 0) or 0) + int(root.get("failures", 0) or 0)
        if errors:
            out.append((os.path.basename(path), True, "%d errors/failures and no test cases" % errors))
    return out


def promised_results(ctest_file):
    """Result file paths that catkin's run_tests.py wrappers in a CTestTestfile.cmake will check."""
    try:
        text = open(ctest_file).read()
    except OSError:
        return []
    return sorted(set(re.findall(r'run_tests\.py"?\s+"?([^"\s]+\.xml)', text)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results_dir")
    ap.add_argument("--ctest-file", help="CTestTestfile.cmake of the package's build folder")
    args = ap.parse_args(argv)

    files = sorted(glob.glob(os.path.join(args.results_dir, "**", "*.xml"), recursive=True))
    passed, failed = 0, []
    for path in files:
        for name, bad, reason in cases_of(path):
            if bad:
                failed.append((name, os.path.basename(path), reason))
            else:
                passed += 1
    if args.ctest_file:
        for promised in promised_results(args.ctest_file):
            missing = os.path.join(os.path.dirname(promised), "MISSING-" + os.path.basename(promised))
            if not os.path.exists(promised) and not os.path.exists(missing):
                failed.append((os.path.basename(promised), "-", "no result file (test killed or never run)"))

    print("Test results in %s: %d files" % (args.results_dir, len(files)))
    for name, where, reason in failed:
        print("  FAILED %s [%s]%s" % (name, where, (": " + reason) if reason else ""))
    if passed + len(failed) == 0:
        print("  nothing ran: no test cases found")
    print("%d passed, %d failed" % (passed, len(failed)))
    return 0 if (passed > 0 and not failed) else 1


if __name__ == "__main__":
    sys.exit(main())
