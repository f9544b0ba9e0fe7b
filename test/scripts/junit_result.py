"""unittest with a JUnit XML result, for the script tests catkin_run_tests_target runs (its
run_tests.py expects a result file): `main(name)` runs the calling module's tests and, given
`--xml RESULT.xml` on the command line, writes one suite named `name`."""
import os
import sys
import unittest
import xml.etree.ElementTree as ET


class JUnitResult(unittest.TextTestResult):
    """Collects each test's failures (subtests included) for a JUnit XML file."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.cases = {}

    def _case(self, test):
        return self.cases.setdefault(test.id(), [])

    def addSuccess(self, test):
        super().addSuccess(test)
        self._case(test)

    def addFailure(self, test, err):
        super().addFailure(test, err)
        self._case(test).append(("failure", self._exc_info_to_string(err, test)))

    def addError(self, test, err):
        super().addError(test, err)
        self._case(test).append(("error", self._exc_info_to_string(err, test)))

    def addSubTest(self, test, subtest, err):
        super().addSubTest(test, subtest, err)
        outcomes = self._case(test)
        if err is not None:
            kind = "failure" if issubclass(err[0], test.failureException) else "error"
            outcomes.append((kind, "%s\n%s" % (subtest, self._exc_info_to_string(err, test))))

    def write_xml(self, path, name):
        suite = ET.Element("testsuite", name=name, tests=str(len(self.cases)),
                           failures=str(sum(1 for o in self.cases.values() if o)), errors="0")
        for test_id, outcomes in sorted(self.cases.items()):
            classname, _, case_name = test_id.rpartition(".")
            case = ET.SubElement(suite, "testcase", classname=classname, name=case_name)
            for kind, text in outcomes:
                ET.SubElement(case, kind, message=text.strip().splitlines()[-1]).text = text
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)


def main(name):
    """Runs the __main__ module's tests; exits 0 when they pass."""
    argv, xml = sys.argv[1:], None
    if "--xml" in argv:
        i = argv.index("--xml")
        xml = argv[i + 1]
        del argv[i:i + 2]
    runner = unittest.TextTestRunner(resultclass=JUnitResult, verbosity=2)
    program = unittest.main(argv=[sys.argv[0]] + argv, testRunner=runner, exit=False)
    if xml:
        program.result.write_xml(xml, name)
    sys.exit(0 if program.result.wasSuccessful() else 1)
