#!/usr/bin/python3
"""`make robustness`'s bookkeeping (scripts/robustness.py), without ROS and without a build.

Runs the script with a fake `rosrun` first on PATH: `calibrate_sim` records its master and
arguments and writes the run's summary (a failure for the robot named in FAKE_FAIL), the
compare_* tools print nothing. Checks that each robot and real-time factor runs once on a master of
its own, that --jobs runs robots at the same time, that every finished run lands in runs.jsonl,
that --first goes on from a robot, and that --table-only counts the runs there without running
anything.

    /usr/bin/python3 test/scripts/test_robustness.py [--xml RESULT.xml] [unittest options]
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import junit_result  # noqa: E402

PKG = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
SCRIPT = os.path.join(PKG, "scripts", "robustness.py")

FAKE_ROSRUN = r'''#!/usr/bin/python3
import json, os, sys, time
if sys.argv[2] != "calibrate_sim":
    sys.exit(0)  # compare_camera, compare_wheels: no figures
args = dict(a.split(":=", 1) for a in sys.argv[3:] if ":=" in a)
start = time.time()
time.sleep(0.4)
summary = os.path.join(args["calibration_root"], "report", args["veh"], "summary.yaml")
os.makedirs(os.path.dirname(summary))
with open(summary, "w") as f:
    if args["veh"] == os.environ.get("FAKE_FAIL"):
        f.write('result: failure\nfailure: "no floor tag in view over a full turn"\n')
    else:
        f.write("result: success\n")
with open(os.environ["FAKE_ROSRUN_LOG"], "a") as log:
    log.write(json.dumps({"master": os.environ["ROS_MASTER_URI"], "veh": args["veh"],
                          "rtf": args["real_time_factor"], "start": start,
                          "end": time.time()}) + "\n")
'''


class RobustnessScriptTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="autocal_robustness_")
        self.bin = os.path.join(self.tmp, "bin")
        os.makedirs(self.bin)
        with open(os.path.join(self.bin, "rosrun"), "w") as f:
            f.write(FAKE_ROSRUN)
        os.chmod(os.path.join(self.bin, "rosrun"), 0o755)
        self.log = os.path.join(self.tmp, "rosrun.jsonl")
        self.out = os.path.join(self.tmp, "out")

    def tearDown(self):
        shutil.rmtree(self.tmp)

    def run_script(self, *args, fail=""):
        env = dict(os.environ, PATH=self.bin + ":/usr/bin:/bin", FAKE_ROSRUN_LOG=self.log,
                   FAKE_FAIL=fail)
        proc = subprocess.run(["/usr/bin/python3", SCRIPT, "--out", self.out] + list(args),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                              timeout=120)
        self.assertEqual(proc.returncode, 0, proc.stderr)
        return proc.stdout

    def launches(self):
        with open(self.log) as f:
            return [json.loads(line) for line in f]

    def rows(self):
        with open(os.path.join(self.out, "runs.jsonl")) as f:
            return [json.loads(line) for line in f]

    def test_each_run_once_on_its_own_master_two_at_a_time(self):
        table = self.run_script("--robots", "3", "--rtf", "1", "3", "--jobs", "2", fail="robot2")
        runs = self.launches()
        self.assertEqual(sorted((r["veh"], r["rtf"]) for r in runs),
                         [("robot%d" % i, rtf) for i in (1, 2, 3) for rtf in ("1", "3")])
        self.assertEqual(len({r["master"] for r in runs}), 6)
        overlapping = any(a is not b and a["start"] < b["end"] and b["start"] < a["end"]
                          for a in runs for b in runs)
        self.assertTrue(overlapping, "--jobs 2 ran one robot at a time")
        self.assertEqual(len(self.rows()), 6)
        self.assertIn("| 1 | 2 of 3 |", table)
        self.assertIn("| 3 | 2 of 3 |", table)
        self.assertIn("* robot2 at 1: no floor tag in view over a full turn", table)

    def test_first_goes_on_and_table_only_counts_every_run(self):
        self.run_script("--robots", "2", "--rtf", "1", "--no-odometry")
        self.run_script("--robots", "4", "--first", "3", "--rtf", "1", "--no-odometry")
        self.assertEqual(sorted(r["veh"] for r in self.launches()),
                         ["robot1", "robot2", "robot3", "robot4"])
        self.assertEqual(sorted(r["robot"] for r in self.rows()),
                         ["robot1", "robot2", "robot3", "robot4"])
        os.remove(self.log)
        table = self.run_script("--robots", "4", "--rtf", "1", "--no-odometry", "--table-only")
        self.assertFalse(os.path.exists(self.log), "--table-only ran something")
        self.assertIn("4 robots drawn", table)
        self.assertIn("| 1 | 4 of 4 |", table)


if __name__ == "__main__":
    junit_result.main("test_robustness")
