#!/usr/bin/python3
"""The package installs as a ROS package: `cmake --install BUILD --prefix TMP` (what
`catkin_make install` runs) puts every executable a launch file of the package starts, every
wrapper command, the launch files and the configs they name where roslaunch and rosrun find them.

    /usr/bin/python3 test/scripts/test_install.py BUILD_DIR [--xml RESULT.xml]
"""
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import junit_result  # noqa: E402

PKG = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
BUILD = None  # from the command line


class Install(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.prefix = tempfile.mkdtemp(prefix="autocal_install_")
        cls.result = subprocess.run(["cmake", "--install", BUILD, "--prefix", cls.prefix],
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        cls.bin = os.path.join(cls.prefix, "lib", "autocal")
        cls.share = os.path.join(cls.prefix, "share", "autocal")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.prefix, ignore_errors=True)

    def test_install_succeeds(self):
        self.assertEqual(self.result.returncode, 0, self.result.stdout[-3000:])

    def test_every_node_a_launch_file_starts_is_installed(self):
        for launch in sorted(glob.glob(os.path.join(PKG, "launch", "*.launch"))):
            for node in ET.parse(launch).getroot().iter("node"):
                if node.get("pkg") != "autocal":
                    continue
                exe = os.path.join(self.bin, node.get("type"))
                with self.subTest(launch=os.path.basename(launch), node=node.get("type")):
                    self.assertTrue(os.access(exe, os.X_OK), "%s is not installed" % exe)

    def test_wrapper_commands_are_installed(self):
        for name in ("calibrate_sim", "replay", "sim_fleet", "odometry_sim"):
            with self.subTest(command=name):
                self.assertTrue(os.access(os.path.join(self.bin, name), os.X_OK), name)
        self.assertTrue(os.path.isfile(os.path.join(self.bin, "launch_args.py")))

    def test_rosrun_offers_what_is_installed_and_nothing_else(self):
        # What `rosrun autocal <Tab>` lists in this build (bash completion's own function), against
        # the installed executables: no test binary, benchmark, helper script or catkin file.
        completion = "/usr/share/bash-completion/completions/rosbash"
        if not os.path.isfile(completion) or not shutil.which("catkin_find"):
            self.skipTest("rosbash completion or catkin_find missing")
        script = ('source %s; COMP_WORDS=(rosrun autocal ""); COMP_CWORD=2; _roscomplete_exe; '
                  'printf "%%s\\n" "${COMPREPLY[@]}"' % completion)
        env = dict(os.environ, ROS_PACKAGE_PATH=PKG + ":" + os.environ.get("ROS_PACKAGE_PATH", ""))
        out = subprocess.run(["bash", "-c", script], stdout=subprocess.PIPE, text=True, env=env)
        offered = set(out.stdout.split())
        installed = {n for n in os.listdir(self.bin) if os.access(os.path.join(self.bin, n), os.X_OK)}
        self.assertEqual(sorted(offered - installed), [], "offered by rosrun, not installed")
        self.assertEqual(sorted(installed - offered), [], "installed, not offered by rosrun")
        for name in offered:
            self.assertNotRegex(name, r"^(test_|bench)|\.(sh|py)$")

    def test_installed_package_calibrates_in_the_simulator(self):
        # `rosrun autocal calibrate_sim` from the installed package alone: the environment names
        # the prefix and Debian's ROS, never this source tree or its build; the run must succeed
        # and write its files, and nothing it prints may name the source tree.
        root = os.path.join(self.prefix, "calibrations")
        home = os.path.join(self.prefix, "ros_home")
        env = {k: v for k, v in os.environ.items()
               if not k.startswith(("ROS", "CATKIN", "CMAKE_PREFIX")) and
               k not in ("PYTHONPATH", "LD_LIBRARY_PATH", "PKG_CONFIG_PATH")}
        env.update(PATH="/usr/bin:/bin", PYTHONNOUSERSITE="1", CMAKE_PREFIX_PATH=self.prefix,
                   ROS_PACKAGE_PATH=os.path.join(self.prefix, "share") + ":/usr/share",
                   PYTHONPATH=os.path.join(self.prefix, "lib", "python3", "dist-packages"),
                   ROS_HOME=home, ROS_MASTER_URI="http://localhost:%d" % (11600 + os.getpid() % 300))
        run = subprocess.run(["rosrun", "autocal", "calibrate_sim", "veh:=installed",
                              "calibration_root:=" + root], cwd=self.prefix, env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                             timeout=600)
        self.assertEqual(run.returncode, 0, run.stdout[-3000:])
        self.assertNotIn(PKG + "/", run.stdout.replace(self.prefix, ""))
        for path in ("camera_intrinsic/installed.yaml", "kinematics/installed.yaml",
                     "report/installed/summary.yaml"):
            self.assertTrue(os.path.isfile(os.path.join(root, path)), path)
        with open(os.path.join(root, "report", "installed", "summary.yaml")) as f:
            self.assertIn("result: success", f.read())

    def test_package_xml_declares_what_the_package_uses(self):
        # rosdep installs what package.xml declares: every catkin component and library CMake
        # finds, every package a launch file starts a node of, every module an installed script
        # imports.
        xml = ET.parse(os.path.join(PKG, "package.xml")).getroot()
        declared = {e.text.strip() for e in xml if e.tag.endswith("depend")}
        with open(os.path.join(PKG, "CMakeLists.txt")) as f:
            cmake = f.read()
        components = re.search(r"find_package\(catkin REQUIRED COMPONENTS([^)]*)\)", cmake)
        needed = {c: "find_package(catkin COMPONENTS %s)" % c for c in components.group(1).split()}
        rosdep_key = {"OpenCV": "libopencv-dev", "Eigen3": "eigen", "yaml-cpp": "yaml-cpp",
                      "box2d": "box2d", "apriltag": "apriltag", "rostest": "rostest",
                      "GTest": "gtest"}
        # catkin's components are checked above; Threads is the compiler's own thread library,
        # with no package to declare.
        toolchain = {"catkin", "Threads"}
        for name in re.findall(r"find_package\((\S+)[^)]*REQUIRED", cmake):
            if name not in toolchain:
                self.assertIn(name, rosdep_key, "find_package(%s): add its rosdep key here" % name)
                needed[rosdep_key[name]] = "find_package(%s)" % name
        for launch in glob.glob(os.path.join(PKG, "launch", "*.launch")):
            for node in ET.parse(launch).getroot().iter("node"):
                # RViz only opens with rviz:=true, on a desktop: not a robot's dependency.
                if node.get("pkg") not in ("autocal", "rviz"):
                    needed[node.get("pkg")] = os.path.basename(launch)
        module_key = {"rospy": "rospy", "rosbag": "rosbag", "yaml": "python3-yaml",
                      "numpy": "python3-numpy", "cv2": "python3-opencv"}
        for name in os.listdir(self.bin):
            path = os.path.join(self.bin, name)
            with open(path, "rb") as f:
                head = f.read(64)
            if head.startswith(b"#!") and b"python" not in head:  # a shell script's ROS tools
                with open(path) as f:
                    for tool in set(re.findall(r"\b(roslaunch|rosbag|rostopic|rosnode|rosrun)\b",
                                               f.read())):
                        needed["rosbash" if tool == "rosrun" else tool] = "%s runs %s" % (name, tool)
                continue
            if not head.startswith(b"#!/usr/bin/python3") and not name.endswith(".py"):
                continue
            with open(path) as f:
                modules = re.findall(r"^\s*(?:import|from)\s+(\w+)", f.read(), re.M)
            for m in modules:
                if m in sys.stdlib_module_names or m in ("autocal", "launch_args"):
                    continue
                self.assertIn(m, module_key, "%s imports %s: add its rosdep key here" % (name, m))
                needed[module_key[m]] = "%s imports %s" % (name, m)
        for key, why in sorted(needed.items()):
            with self.subTest(key=key):
                self.assertIn(key, declared, "package.xml lacks <depend>%s</depend> (%s)" % (key, why))

    def test_one_launch_file_composes_the_stages(self):
        # calibrate.launch composes the live stages; the simulator's run and the fleet include it.
        # No other file starts both driving stages (a replay is `rosrun autocal replay`, no launch).
        composers = []
        for launch in sorted(glob.glob(os.path.join(PKG, "launch", "*.launch"))):
            included = {os.path.basename(i.get("file", ""))
                        for i in ET.parse(launch).getroot().iter("include")}
            if {"camera_calibration.launch", "wheel_calibration.launch"} <= included:
                composers.append(os.path.basename(launch))
            if os.path.basename(launch) in ("calibrate_sim.launch", "fleet_robot.launch"):
                self.assertIn("calibrate.launch", included, launch)
        self.assertEqual(composers, ["calibrate.launch"])

    def test_launch_files_and_the_files_they_find_are_installed(self):
        for launch in sorted(glob.glob(os.path.join(PKG, "launch", "*.launch"))):
            rel = os.path.relpath(launch, PKG)
            with self.subTest(launch=rel):
                self.assertTrue(os.path.isfile(os.path.join(self.share, rel)), rel)
            with open(launch) as f:
                text = f.read()
            for path in re.findall(r"\$\(find autocal\)/([\w./-]+)", text):
                with self.subTest(launch=rel, path=path):
                    self.assertTrue(os.path.exists(os.path.join(self.share, path)),
                                    "%s names %s, not installed" % (rel, path))


if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1].startswith("-"):
        sys.exit(__doc__)
    BUILD = os.path.abspath(sys.argv.pop(1))
    junit_result.main("test_install")
