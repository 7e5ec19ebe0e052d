#!/usr/bin/env python3
"""The slowest tests of a CTest run, from the JUnit file CTest wrote (ctest --output-junit FILE).

Usage: scripts/slowest_tests.py JUNIT.xml [N]   (default N 15; scripts/test.sh prints it after every run)
Prints N lines `SECONDS  STATUS  NAME`, slowest first, then the sum of every test's seconds.
"""
import sys
import xml.etree.ElementTree as ElementTree


def main(argv):
    if len(argv) not in (2, 3) or argv[1] in ("-h", "--help"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    path = argv[1]
    count = int(argv[2]) if len(argv) == 3 else 15
    try:
        root = ElementTree.parse(path).getroot()
    except (OSError, ElementTree.ParseError) as error:
        print(f"slowest_tests: {path}: {error}", file=sys.stderr)
        return 1
    tests = []
    for case in root.iter("testcase"):
        status = case.get("status", "run")
        if case.find("failure") is not None:
            status = "failed"
        elif case.find("skipped") is not None:
            status = "skipped"
        tests.append((float(case.get("time", "0")), status, case.get("name", "?")))
    tests.sort(key=lambda test: -test[0])
    print(f"The {min(count, len(tests))} slowest of {len(tests)} tests (seconds, from {path}):")
    for seconds, status, name in tests[:count]:
        print(f"{seconds:9.1f}  {status:8s} {name}")
    print(f"{sum(test[0] for test in tests):9.1f}  in all (the suite runs on both cores at once)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
