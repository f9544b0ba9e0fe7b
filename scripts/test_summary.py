#!/usr/bin/env python3
"""Summarise catkin's JUnit results: print each failure, then one line `N passed, N failed`.

Usage: test_summary.py RESULTS_DIR RUN_TESTS_LOG RUN_TESTS_STATUS
Exits non-zero when any test failed, when no result was written, or when run_tests failed.
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET


# A failure's message is printed whole up to this many characters: CI shows only this summary,
# and the cause (a stage's FAILED reason) comes after gtest's "Expected equality" lines.
MAX_MESSAGE_CHARS = 2000


def message(bad):
    """A <failure>'s or <error>'s text on one line: its message and its body, lines joined by |."""
    lines = []
    for part in (bad.get('message') or '', bad.text or ''):
        for line in part.strip().splitlines():
            line = line.strip()
            if line and line not in lines:
                lines.append(line)
    text = ' | '.join(lines)
    if len(text) > MAX_MESSAGE_CHARS:
        text = text[:MAX_MESSAGE_CHARS] + ' ...'
    return text


def main():
    results_dir, log_path, status = sys.argv[1], sys.argv[2], int(sys.argv[3])
    passed, failed, failures = 0, 0, []
    files = sorted(glob.glob(os.path.join(results_dir, '**', '*.xml'), recursive=True))
    for path in files:
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as exc:
            failed += 1
            failures.append('%s: unreadable result (%s)' % (os.path.basename(path), exc))
            continue
        cases = root.iter('testcase')
        for case in cases:
            name = '%s.%s' % (case.get('classname', ''), case.get('name', ''))
            bad = case.find('failure')
            if bad is None:
                bad = case.find('error')
            if case.find('skipped') is not None and bad is None:
                continue
            if bad is None:
                passed += 1
            else:
                failed += 1
                failures.append('%s (%s): %s' % (name, os.path.basename(path), message(bad)))
    for line in failures:
        print('FAILED ' + line)
    if status != 0:
        print('run_tests exited with %d; see %s' % (status, log_path))
        failed += 0 if failures else 1
    if not files:
        print('no test results under %s; see %s' % (results_dir, log_path))
        failed += 1
    print('%d passed, %d failed' % (passed, failed))
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
