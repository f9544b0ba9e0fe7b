#!/usr/bin/python3
"""The documentation against the code, without ROS and without a build.

Fails when
  (a) a private parameter a node reads (ParamReader's p.get("name", ...) or p.require("name", ...)
      in the node's sources, including the shared helpers it calls, e.g. readTagParams) has no
      row `~name` in the Parameters table of its page doc/nodes/<node>.md;
  (b) a page's Parameters table lists a `~name` the code no longer reads;
  (c) README.md is longer than 260 lines;
  (d) README.md, BENCHMARKS.md or a file under doc/ names a tracker issue ("issue" and a number),
      DESIGN.md or ../shared, or holds a date such as YYYY-MM-DD (history goes to CHANGELOG.rst);
  (e) a relative link in README.md or doc/**/*.md points to a file that does not exist;
  (f) a failure reason a stage can publish (the text of fail("..."), failure_ = "...", or a thrown
      CalibrationError or InputError in the files of FAILURE_SOURCES) is not in
      doc/troubleshooting.md;
and checks that every node page follows the one template, and that no node reading parameters is
missing from the mapping below (a new node, or a new shared helper, must be added to it).

    /usr/bin/python3 test/scripts/test_docs.py [--xml RESULT.xml] [unittest options]

Runs from any directory: the package is found from this file's path. --xml also writes a JUnit
result (for catkin_run_tests_target, as test_wrappers.py).
"""
import glob
import os
import re
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import junit_result  # noqa: E402

PKG = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))

# Each node's documentation page (doc/nodes/<node>.md) and the sources whose ParamReader calls are
# its private parameters: the node's own file and every shared helper it calls with its
# ParamReader (src/ros/autocal_ros/tag_params.cpp: readTagParams, for the nodes that sight floor
# tags; src/ros/autocal_ros/stage_node.cpp: readStageNodeOptions, for the stage nodes). Paths are relative to the package. A node without parameters has an empty list.
NODES = {
    "camera_calibration_node": ["src/nodes/camera_calibration/camera_calibration_node.cpp",
                                "src/ros/autocal_ros/stage_node.cpp"],
    "wheel_calibration_node": ["src/nodes/wheel_calibration/wheel_calibration_node.cpp",
                               "src/ros/autocal_ros/tag_params.cpp",
                               "src/ros/autocal_ros/stage_node.cpp"],
    "odometry_calibration_node": ["src/nodes/odometry_calibration/odometry_calibration_node.cpp",
                                  "src/ros/autocal_ros/stage_node.cpp"],
    "kinematics_node": ["src/nodes/kinematics/kinematics_node.cpp"],
    "lane_refinement_node": ["src/nodes/lane_refinement/lane_refinement_node.cpp",
                             "src/nodes/lane_refinement/lane_refinement_options.cpp",
                             "src/ros/autocal_ros/tag_params.cpp"],
    "run_report_node": ["src/nodes/run_report/run_report_node.cpp"],
    "camera_view_node": ["src/nodes/run_report/camera_view_node.cpp"],
    "focus_node": ["src/nodes/focus/focus_node.cpp"],
    "fleet_report_node": ["src/nodes/run_report/fleet_report_main.cpp"],
    "validate_straight": ["src/nodes/validate_straight/validate_straight_node.cpp"],
    "sim_node": ["sim/src/node/sim_node.cpp"],
    "straight_length_helper": [],
    "umbmark_error_helper": [],
}

# Private parameters a node has that are not read with ParamReader, each with where they come
# from: a (file, regex) whose first group is the name, or a fixed name with the reason.
OTHER_PARAMS = {
    # kinematicsFields(): the kinematics file's keys, set as ~gain, ~trim, ... and polled.
    "kinematics_node": [("src/core/wheels/kinematics.cpp", r'\{"(\w+)",\s*&KinematicsParams::')],
    # diagnostic_updater reads ~diagnostic_period from the node's private handle.
    "run_report_node": ["diagnostic_period"],
}

# The template of a node or command page: these sections, in this order.
TEMPLATE = ["Subscribed topics", "Published topics", "Services", "Parameters", "Files",
            "Exit codes"]
README_MAX_LINES = 260
HISTORY_MARKERS = [
    (re.compile(r"\bissues?\s+#?\d+", re.IGNORECASE), "a tracker issue number"),
    (re.compile(r"DESIGN\.md"), "DESIGN.md (not in the repository)"),
    (re.compile(r"\.\./shared\b"), "../shared (not in a user's clone)"),
    (re.compile(r"\b(19|20)\d\d-[01]\d-[0-3]\d\b"), "a date (history belongs in CHANGELOG.rst)"),
]


def read(rel):
    with open(os.path.join(PKG, rel), encoding="utf-8") as f:
        return f.read()


def strip_cpp_comments(text):
    """The text without // and /* */ comments (string literals kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(text[i:j + 1])
            i = j + 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            i = n if j < 0 else j + 2
        else:
            out.append(c)
            i += 1
    return "".join(out)


def reader_names(code):
    """The names of the ParamReader objects a file uses (p in `ParamReader p(...)`)."""
    return set(re.findall(r"\bParamReader\s*&?\s+(\w+)\s*[(,)]", code))


def params_read(rel):
    """The parameter names a source reads with ParamReader::get / require."""
    code = strip_cpp_comments(read(rel))
    names = reader_names(code)
    if not names:
        return set()
    pattern = r"\b(?:%s)\.(?:get|require)\(\s*\"([A-Za-z0-9_]+)\"" % "|".join(map(re.escape, names))
    return set(re.findall(pattern, code))


def code_params(node):
    found = set()
    for rel in NODES[node]:
        found |= params_read(rel)
    for other in OTHER_PARAMS.get(node, []):
        if isinstance(other, tuple):
            found |= set(re.findall(other[1], strip_cpp_comments(read(other[0]))))
        else:
            found.add(other)
    return found


def sections(markdown):
    """{heading: body} of a page's level-2 sections, and the headings in order."""
    parts = re.split(r"^## +(.+?) *$", markdown, flags=re.MULTILINE)
    order = [parts[i] for i in range(1, len(parts), 2)]
    return dict(zip(order, parts[2::2])), order


def page(node):
    return "doc/nodes/%s.md" % node


def documented_params(node):
    """The `~name`s in the first column of the page's Parameters table."""
    body = sections(read(page(node)))[0].get("Parameters", "")
    return re.findall(r"^\|\s*`~([A-Za-z0-9_]+)`\s*\|", body, flags=re.MULTILINE)


def markdown_files():
    files = ["README.md"] + sorted(
        os.path.relpath(p, PKG) for p in glob.glob(os.path.join(PKG, "doc", "**", "*.md"),
                                                   recursive=True))
    return files


def text_files_checked_for_history():
    files = ["README.md", "BENCHMARKS.md"]
    for path in sorted(glob.glob(os.path.join(PKG, "doc", "**", "*"), recursive=True)):
        if os.path.isfile(path) and not path.endswith((".png", ".jpg", ".jpeg", ".gif")):
            files.append(os.path.relpath(path, PKG))
    return files


def without_code(markdown):
    """The text without fenced code blocks and inline code spans (no links live there)."""
    markdown = re.sub(r"^```.*?^```", "", markdown, flags=re.MULTILINE | re.DOTALL)
    return re.sub(r"`[^`\n]*`", "", markdown)


LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


class NodeParameterTest(unittest.TestCase):
    def test_mapping_names_existing_files(self):
        for node, sources in NODES.items():
            with self.subTest(node=node):
                self.assertTrue(os.path.isfile(os.path.join(PKG, page(node))),
                                "%s has no page %s" % (node, page(node)))
                for rel in sources:
                    self.assertTrue(os.path.isfile(os.path.join(PKG, rel)),
                                    "%s: source %s does not exist" % (node, rel))

    def test_every_parameter_reading_source_is_mapped(self):
        # A node whose file constructs a ParamReader must be in NODES, or its parameters would
        # go unchecked.
        mapped = {rel for sources in NODES.values() for rel in sources}
        for path in sorted(glob.glob(os.path.join(PKG, "src", "**", "*.cpp"), recursive=True) +
                           glob.glob(os.path.join(PKG, "sim", "**", "*.cpp"), recursive=True)):
            rel = os.path.relpath(path, PKG)
            code = strip_cpp_comments(read(rel))
            if re.search(r"\bParamReader\s+\w+\s*\(", code):
                with self.subTest(source=rel):
                    self.assertIn(rel, mapped, "%s reads parameters but is in no node's list "
                                  "(test/scripts/test_docs.py NODES)" % rel)

    def test_shared_helpers_are_listed_with_their_callers(self):
        # A helper of the ROS layer that reads parameters through a ParamReader it is given
        # (readTagParams) adds to every node that calls it.
        helpers = {}
        for path in glob.glob(os.path.join(PKG, "src", "ros", "**", "*.cpp"), recursive=True):
            rel = os.path.relpath(path, PKG)
            code = strip_cpp_comments(read(rel))
            for name in re.findall(r"\b(\w+)\s*\(\s*const\s+ParamReader\s*&", code):
                if params_read(rel):
                    helpers[name] = rel
        self.assertIn("readTagParams", helpers)
        for node, sources in NODES.items():
            for rel in sources:
                if rel in helpers.values():
                    continue
                code = strip_cpp_comments(read(rel))
                for name, helper in helpers.items():
                    if re.search(r"\b%s\s*\(" % re.escape(name), code):
                        with self.subTest(node=node, helper=name):
                            self.assertIn(helper, sources, "%s calls %s: add %s to its sources"
                                          % (node, name, helper))

    def test_every_parameter_read_is_documented(self):
        for node in NODES:
            with self.subTest(node=node):
                missing = sorted(code_params(node) - set(documented_params(node)))
                self.assertEqual(missing, [], "%s reads %s, which %s does not list" % (
                    node, ", ".join("~" + p for p in missing), page(node)))

    def test_every_documented_parameter_is_read(self):
        for node in NODES:
            with self.subTest(node=node):
                listed = documented_params(node)
                stale = sorted(set(listed) - code_params(node))
                self.assertEqual(stale, [], "%s lists %s, which the code does not read" % (
                    page(node), ", ".join("~" + p for p in stale)))
                twice = sorted({p for p in listed if listed.count(p) > 1})
                self.assertEqual(twice, [], "%s lists %s twice" % (page(node), twice))

    def test_node_pages_follow_the_template(self):
        for path in sorted(glob.glob(os.path.join(PKG, "doc", "nodes", "*.md"))):
            rel = os.path.relpath(path, PKG)
            if os.path.basename(path) == "README.md":
                continue
            with self.subTest(page=rel):
                text = read(rel)
                self.assertTrue(text.startswith("# "), "%s has no title" % rel)
                order = [h for h in sections(text)[1] if h in TEMPLATE]
                self.assertEqual(order, TEMPLATE, "%s: sections %s, expected %s" % (
                    rel, order, TEMPLATE))


# The sources whose failure texts a stage publishes as its FAILED reason (its core run and the
# parts that fail it, its node, the ROS layer's shared waits and checks).
FAILURE_SOURCES = [
    "src/core/camera/sweep_run.cpp", "src/core/camera/sweep_controller.cpp",
    "src/core/camera/min_duty_probe.cpp", "src/core/camera/calibration.cpp",
    "src/nodes/camera_calibration/camera_calibration_node.cpp",
    "src/core/wheels/wheel_run.cpp", "src/core/wheels/wheel_run_output.cpp",
    "src/core/wheels/trim_estimator.cpp",
    "src/nodes/wheel_calibration/wheel_calibration_node.cpp",
    "src/core/odometry/uah_run.cpp", "src/core/odometry/umbmark_run.cpp",
    "src/nodes/odometry_calibration/odometry_calibration_node.cpp",
    "src/ros/autocal_ros/node_runtime.cpp", "src/ros/autocal_ros/msg_conversion.cpp",
    "src/ros/autocal_ros/stage_node.cpp", "src/ros/autocal_ros/sensor_inputs.cpp",
    "src/core/replay/run_replay.cpp", "src/ros/autocal_ros/recording.cpp",
]
# A failure's first string literal (after an optional variable and +): the text the page must hold.
FAILURE = re.compile(r'(?:\bfail\(|failure_ =|throw (?:Calibration|Input)Error\()\s*'
                     r'(?:[a-z_]+ \+ )?"((?:[^"\\]|\\.)*)"')


class TroubleshootingTest(unittest.TestCase):
    def test_every_failure_reason_is_documented(self):
        page = read("doc/troubleshooting.md")
        for rel in FAILURE_SOURCES:
            for literal in FAILURE.findall(read(rel)):
                text = literal.replace('\\"', '"').strip(' :;("\'')
                if len(text) < 8:
                    continue  # a fragment ("only ", "view "): its row names the whole reason
                with self.subTest(file=rel, reason=text):
                    self.assertTrue(text in page, "%s can fail with '%s...', which "
                                  "doc/troubleshooting.md does not list" % (rel, text))


class DocumentTest(unittest.TestCase):
    def test_readme_is_short(self):
        lines = read("README.md").count("\n")
        self.assertLessEqual(lines, README_MAX_LINES,
                             "README.md has %d lines (at most %d: the reference goes to doc/)"
                             % (lines, README_MAX_LINES))

    def test_no_history_in_reference_pages(self):
        for rel in text_files_checked_for_history():
            for number, line in enumerate(read(rel).splitlines(), 1):
                for pattern, what in HISTORY_MARKERS:
                    match = pattern.search(line)
                    if match:
                        with self.subTest(file=rel, line=number):
                            self.fail("%s:%d: %s: '%s'" % (rel, number, what, match.group(0)))

    def test_relative_links_resolve(self):
        for rel in markdown_files():
            base = os.path.dirname(os.path.join(PKG, rel))
            for target in LINK.findall(without_code(read(rel))):
                if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target) or target.startswith("#"):
                    continue  # http:, mailto:, or an anchor in the same page
                path = target.split("#", 1)[0]
                with self.subTest(file=rel, link=target):
                    self.assertFalse(os.path.isabs(path), "%s: absolute link %s" % (rel, target))
                    self.assertTrue(os.path.exists(os.path.normpath(os.path.join(base, path))),
                                    "%s: the link %s points to nothing" % (rel, target))


if __name__ == "__main__":
    junit_result.main("test_docs")
