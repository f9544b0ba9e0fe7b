#!/usr/bin/python3
"""The wrapper commands' argument check (scripts/launch_args.py), without ROS and without a build.

Runs scripts/calibrate_sim, sim_fleet and odometry_sim by path with a fake `roslaunch`
first on PATH: it records its argv and, from its own cwd $ROS_HOME as the real nodes, writes the
files the wrapper judges the run by (summary.yaml result: success, or odometry/VEH.yaml). Checks
that a typo'd or malformed argument is refused with status 64 naming it and the nearest valid name
and that nothing was launched, that -h/--help lists the arguments, and that relative and ~ paths
reach roslaunch absolute, from the directory the command ran in, and the wrapper reads its result
there.

    /usr/bin/python3 test/scripts/test_wrappers.py [--xml RESULT.xml] [unittest options]

--xml also writes a JUnit result (for catkin_run_tests_target, whose run_tests.py expects one).
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import junit_result  # noqa: E402
import xml.etree.ElementTree as ET

PKG = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
SCRIPTS = os.path.join(PKG, "scripts")
LAUNCH = os.path.join(PKG, "launch")
WRAPPERS = {"calibrate_sim": "calibrate_sim.launch", "sim_fleet": "sim_fleet.launch",
            "odometry_sim": "odometry_sim.launch"}

FAKE_ROSLAUNCH = r'''#!/usr/bin/python3
import json, os, sys
with open(os.environ["FAKE_ROSLAUNCH_LOG"], "a") as log:
    log.write(json.dumps(sys.argv[1:]) + "\n")
launch = sys.argv[2]
args = dict(a.split(":=", 1) for a in sys.argv[3:] if ":=" in a)
root = args.get("calibration_root", os.path.join(os.environ["PWD"], "calibrations"))
os.chdir(os.environ["ROS_HOME"])  # the nodes' cwd: a relative path lands here
result = os.environ.get("FAKE_RESULT", "success")


def write(path, text):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(text)


if launch == "sim_fleet.launch":
    for k in range(1, int(args.get("n", "2")) + 1):
        write(os.path.join(root, "report", "robot%d" % k, "summary.yaml"), "result: %s\n" % result)
elif launch == "odometry_sim.launch":
    if result == "success":
        write(os.path.join(root, "odometry", args.get("veh", "autobot") + ".yaml"), "k: 1\n")
else:
    text = ("result: success\n" if result == "success"
            else 'result: failure\nfailure: "%s"\n' % result)
    write(os.path.join(root, "report", args.get("veh", "autobot"), "summary.yaml"), text)
'''


class WrapperTest(unittest.TestCase):
    def setUp(self):
        self.tmp = os.path.realpath(tempfile.mkdtemp(prefix="autocal_wrappers_"))
        self.addCleanup(shutil.rmtree, self.tmp)
        self.bin, self.cwd, self.home, self.ros_home = (
            os.path.join(self.tmp, d) for d in ("bin", "cwd", "home", "ros_home"))
        for d in (self.bin, self.cwd, self.home, self.ros_home):
            os.makedirs(d)
        fake = os.path.join(self.bin, "roslaunch")
        with open(fake, "w") as f:
            f.write(FAKE_ROSLAUNCH)
        os.chmod(fake, 0o755)
        self.log = os.path.join(self.tmp, "roslaunch.log")

    def run_wrapper(self, name, *args, result="success"):
        env = {"PATH": self.bin + ":/usr/bin:/bin", "HOME": self.home, "ROS_HOME": self.ros_home,
               "PWD": self.cwd, "ROS_PACKAGE_PATH": PKG, "FAKE_ROSLAUNCH_LOG": self.log,
               "FAKE_RESULT": result, "LANG": "C.UTF-8"}
        return subprocess.run([os.path.join(SCRIPTS, name)] + list(args), cwd=self.cwd, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=60)

    def launches(self):
        if not os.path.exists(self.log):
            return []
        with open(self.log) as f:
            return [json.loads(line) for line in f]

    def launched_args(self):
        calls = self.launches()
        self.assertEqual(len(calls), 1, "roslaunch should run once: %s" % calls)
        return calls[0]

    def assert_refused(self, proc, *words):
        self.assertEqual(proc.returncode, 64, proc.stdout + proc.stderr)
        for word in words:
            self.assertIn(word, proc.stderr)
        self.assertEqual(self.launches(), [], "roslaunch must not run")

    # --- unknown and malformed arguments ---

    def test_typo_refused_with_nearest(self):
        cases = [("calibrate_sim", "calibraton_root:=/data/x", "calibration_root"),
                 ("sim_fleet", "robot_cofigs:=a.yaml,b.yaml", "robot_configs"),
                 ("odometry_sim", "wheel_radius:=0.03", "wheel_radius_m")]
        for wrapper, arg, nearest in cases:
            with self.subTest(wrapper=wrapper):
                proc = self.run_wrapper(wrapper, "veh:=bot", arg)
                self.assert_refused(proc, arg.split(":=")[0], "did you mean " + nearest)
                self.assertIn("valid arguments", proc.stderr)

    def test_not_name_value_refused(self):
        for arg, words in [("--screen", ["--screen"]),
                           ("calibration_root=/x", ["calibration_root=/x", "calibration_root:=/x"]),
                           ("relcal", ["relcal"])]:
            with self.subTest(arg=arg):
                self.assert_refused(self.run_wrapper("calibrate_sim", arg), *words)

    def test_fixed_value_arg_refused(self):
        self.assert_refused(self.run_wrapper("sim_fleet", "_vehicles:=robot1"), "_vehicles")

    def test_help_lists_arguments(self):
        for wrapper, launch in WRAPPERS.items():
            for flag in ("-h", "--help"):
                with self.subTest(wrapper=wrapper, flag=flag):
                    proc = self.run_wrapper(wrapper, flag)
                    self.assertEqual(proc.returncode, 0, proc.stderr)
                    self.assertIn("usage: rosrun autocal " + wrapper, proc.stdout)
                    for name in settable_args(launch):
                        self.assertRegex(proc.stdout, r"\n  %s +" % re.escape(name))
                    self.assertEqual(self.launches(), [])

    # --- relative paths ---

    def test_calibrate_sim_relative_root(self):
        proc = self.run_wrapper("calibrate_sim", "calibration_root:=relcal")
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        root = os.path.join(self.cwd, "relcal")
        self.assertEqual(self.launched_args(),
                         ["autocal", "calibrate_sim.launch", "calibration_root:=" + root])
        self.assertIn("the run succeeded; report in %s/report/autobot" % root, proc.stdout)

    def test_calibrate_sim_relative_configs(self):
        proc = self.run_wrapper("calibrate_sim", "robot_config:=sim/config/fleet/robot_wide.yaml",
                                "world_config:=../w.yaml", "bag_file:=./b/x.bag", "veh:=bot",
                                "seed:=3", "calibration_root:=~/cal")
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        self.assertEqual(self.launched_args()[2:], [
            "robot_config:=%s/sim/config/fleet/robot_wide.yaml" % self.cwd,
            "world_config:=%s/w.yaml" % self.tmp, "bag_file:=%s/b/x.bag" % self.cwd, "veh:=bot",
            "seed:=3", "calibration_root:=%s/cal" % self.home])
        self.assertIn("report in %s/cal/report/bot" % self.home, proc.stdout)

    def test_calibrate_sim_failure_still_exits_1(self):
        proc = self.run_wrapper("calibrate_sim", "calibration_root:=relcal",
                                result="the camera died")
        self.assertEqual(proc.returncode, 1, proc.stdout + proc.stderr)
        self.assertIn("FAILED: the camera died", proc.stderr)

    def test_sim_fleet_relative_paths(self):
        proc = self.run_wrapper("sim_fleet", "n:=3", "calibration_root:=fleet",
                                "robot_configs:=a.yaml, sub/b.yaml,/abs/c.yaml",
                                "robot_config:=r.yaml", "world_config:=")
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        self.assertEqual(self.launched_args()[2:], [
            "n:=3", "calibration_root:=%s/fleet" % self.cwd,
            "robot_configs:={0}/a.yaml,{0}/sub/b.yaml,/abs/c.yaml".format(self.cwd),
            "robot_config:=%s/r.yaml" % self.cwd, "world_config:="])
        for k in (1, 2, 3):
            self.assertIn("robot%d: succeeded; report in %s/fleet/report/robot%d"
                          % (k, self.cwd, k), proc.stdout)

    def test_odometry_sim_relative_root(self):
        proc = self.run_wrapper("odometry_sim", "calibration_root:=odo", "veh:=mybot",
                                "errors_file:=errors.yaml", "method:=umbmark")
        self.assertEqual(proc.returncode, 0, proc.stdout + proc.stderr)
        self.assertEqual(self.launched_args()[2:], [
            "calibration_root:=%s/odo" % self.cwd, "veh:=mybot",
            "errors_file:=%s/errors.yaml" % self.cwd, "method:=umbmark"])
        self.assertIn("odometry_sim: wrote %s/odo/odometry/mybot.yaml" % self.cwd, proc.stdout)

    def test_every_path_arg_resolved(self):
        """Every path-like <arg> of each wrapper's launch file reaches roslaunch absolute (a path
        <arg> added to a launch file but not to launch_args.PATH_ARGS fails here)."""
        for wrapper, launch in WRAPPERS.items():
            with self.subTest(wrapper=wrapper):
                if os.path.exists(self.log):
                    os.remove(self.log)
                names = settable_args(launch)
                paths = [n for n in names if looks_like_path(launch, n)]
                self.assertIn("calibration_root", paths)
                given = ["%s:=rel_%s" % (n, n) for n in paths]
                self.run_wrapper(wrapper, *given)
                got = self.launched_args()[2:]
                self.assertEqual(got, ["%s:=%s/rel_%s" % (n, self.cwd, n) for n in paths])


def settable_args(launch):
    root = ET.parse(os.path.join(LAUNCH, launch)).getroot()
    return [a.get("name") for a in root.findall("arg") if "value" not in a.attrib]


def looks_like_path(launch, name):
    """A path: a name like one, or a default built from $(find), $(env ...) or another path."""
    root = ET.parse(os.path.join(LAUNCH, launch)).getroot()
    default = next(a.get("default") or "" for a in root.findall("arg") if a.get("name") == name)
    return (re.search(r"(^bag|_root|_config|_configs|_file|_dir|_path)$", name) is not None
            or re.search(r"\$\((find|env) |find\('|\.(yaml|bag)\b", default) is not None)


if __name__ == "__main__":
    junit_result.main("test_wrappers")
