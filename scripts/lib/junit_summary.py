"""Counts test cases in a folder of JUnit XML files (gtest, rostest, pytest, roslaunch checks).

catkin_test_results adds up the suite totals, which counts a gtest run twice and a rostest once for
its wrapper and once for the test node; this counts each test case once. A rostest wrapper file's
own case is counted only when it failed (the test node crashed or timed out before writing its file).
Prints every failing case, then "N passed, N failed, N skipped"; exits 1 on any failure or no test.
Usage: python3 junit_summary.py RESULTS_DIR [EXTRA_FAILURES]
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def count(results_dir):
    passed, failed, skipped, failures = 0, 0, 0, []
    for path in sorted(glob.glob(os.path.join(results_dir, '**', '*.xml'), recursive=True)):
        name = os.path.basename(path)
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as e:
            failed += 1
            failures.append('%s: unreadable result file (%s)' % (name, e))
            continue
        for case in root.iter('testcase'):
            label = '%s: %s.%s' % (name, case.get('classname', ''), case.get('name', ''))
            bad = case.find('failure')
            if bad is None:
                bad = case.find('error')
            if bad is not None:
                failed += 1
                failures.append('%s: %s' % (label, (bad.get('message') or bad.text or '').strip()[:300]))
            elif name.startswith('rostest-'):
                continue
            elif case.find('skipped') is not None or case.get('status') == 'notrun':
                skipped += 1
            else:
                passed += 1
    return passed, failed, skipped, failures


def main():
    passed, failed, skipped, failures = count(sys.argv[1])
    failed += int(sys.argv[2]) if len(sys.argv) > 2 else 0
    for line in failures:
        print('FAILED ' + line)
    print('%d passed, %d failed, %d skipped' % (passed, failed, skipped))
    return 0 if failed == 0 and passed > 0 else 1


if __name__ == '__main__':
    sys.exit(main())
