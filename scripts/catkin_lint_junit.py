#!/usr/bin/python3
"""Runs catkin_lint on the package at its default level and writes the verdict as a JUnit result.

    catkin_lint_junit.py PACKAGE_DIR RESULT_XML

One test case, `catkin_lint`: it fails when catkin_lint reports an error (warnings are fixed, or explained
in a `#catkin_lint: ignore` comment in CMakeLists.txt). make test puts the file beside the gtest and
rostest results, so scripts/test_summary.py counts it. Exit status 0 unless catkin_lint could not run.
"""
import subprocess
import sys
from xml.sax.saxutils import escape


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    package_dir, result_xml = argv[1], argv[2]
    try:
        done = subprocess.run(["catkin_lint", package_dir], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              universal_newlines=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as error:
        print("catkin_lint_junit: catkin_lint did not run: %s" % error, file=sys.stderr)
        return 1
    errors = [line for line in done.stdout.splitlines() if ": error: " in line]
    failure = ""
    if errors:
        failure = '<failure message="%s">%s</failure>' % (escape(errors[0], {'"': "&quot;"}),
                                                          escape("\n".join(errors)))
    with open(result_xml, "w") as out:
        out.write('<?xml version="1.0" encoding="UTF-8"?>\n<testsuite name="catkin_lint" tests="1" failures="%d">'
                  '<testcase classname="lint" name="catkin_lint">%s</testcase></testsuite>\n'
                  % (1 if errors else 0, failure))
    print("catkin_lint: %s" % ("%d error(s): %s" % (len(errors), errors[0]) if errors else "no errors"))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
