#!/usr/bin/env python3
"""make test's runner: every test target catkin made for the package, in two groups.

Usage: run_tests.py BUILD_DIR LOG [--jobs N] [--list]

- Tests that do not depend on the wall clock run N at a time (default 2, the machine's cores): the
  gtests, the Python tests, and the rostests whose simulator runs in lockstep with the node that
  drives it or that start no simulator. Each is deterministic on a loaded machine.
- Tests whose simulator runs on the wall clock without lockstep (robot mode, and the stage tests
  paced at a fixed real-time factor) run afterwards, one at a time, with the machine to themselves:
  another test beside them would be a slower robot computer than the one they were tuned on.

A rostest's group comes from its launch file as roslaunch resolves it (`roslaunch --dump-params`):
a `real_time_factor` parameter with no `lockstep_s`, or with `lockstep_s` 0, puts it in the second
group. Nothing is listed by hand.

Each test's output is appended to LOG when it ends (parallel tests do not interleave).
Exits with the first non-zero status of a test target, else 0; the results are catkin's JUnit files.
"""
import argparse
import glob
import os
import re
import subprocess
import sys
import time

PKG = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
PREFIX = 'run_tests_autocal_'
# Run first in their group, longest first (whole stages in the simulator, the installed package's
# calibration), so that the slots end together rather than one long test running alone at the end.
LONG_FIRST = ['sweep_run_in_sim', 'wheel_run_in_sim', 'test_install', 'sim_fleet', 'replay',
              'calibrate_run', 'uah_bag', 'lane_refiner_in_sim', '_in_sim']


def long_first(name):
    return next((i for i, p in enumerate(LONG_FIRST) if p in name), len(LONG_FIRST))


def test_targets(build_dir):
    """The leaf test targets catkin generated (gtest_X, rostest_X.test, python_X)."""
    out = subprocess.run(['cmake', '--build', build_dir, '--target', 'help'], check=True,
                         stdout=subprocess.PIPE, text=True).stdout
    names = re.findall(r'^\.\.\. ' + PREFIX + r'((?:gtest|rostest|python)_\S+)$', out, re.M)
    return sorted(set(names))


def launch_file(rostest_name, files):
    """The .test file of target `rostest_<name>`: catkin names it after the file's path below the
    package with / as _, or after the file's stem followed by __ and its arguments."""
    name = rostest_name[len('rostest_'):]
    for path in files:
        rel = os.path.relpath(path, PKG)
        if rel.replace('/', '_') == name:
            return path
    stem = name.split('__')[0]
    matches = [p for p in files if os.path.basename(p) == stem + '.test']
    if len(matches) != 1:
        raise SystemExit('run_tests.py: no single .test file for target %s%s' % (PREFIX, rostest_name))
    return matches[0]


def on_wall_clock(path):
    """True when the launch file starts a simulator that runs on the wall clock without lockstep."""
    out = subprocess.run(['roslaunch', '--dump-params', path], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    if out.returncode != 0:
        raise SystemExit('run_tests.py: roslaunch --dump-params %s failed:\n%s' % (path, out.stdout))
    params = dict(re.findall(r'^(\S+): (.*)$', out.stdout, re.M))
    for key in params:
        if key.endswith('/real_time_factor'):
            lockstep = params.get(key[:-len('real_time_factor')] + 'lockstep_s', '0')
            if float(lockstep) == 0:
                return True
    return False


def groups(build_dir):
    files = sorted(glob.glob(os.path.join(PKG, 'test', '**', '*.test'), recursive=True))
    free, paced, cache = [], [], {}
    for name in test_targets(build_dir):
        if name.startswith('rostest_'):
            path = launch_file(name, files)
            if path not in cache:
                cache[path] = on_wall_clock(path)
            if cache[path]:
                paced.append(name)
                continue
        free.append(name)
    free.sort(key=long_first)
    return free, paced


def run(build_dir, names, jobs, log):
    """Runs the targets `jobs` at a time (catkin's `_` targets, which build nothing: make test
    built the tests first); returns the first non-zero status."""
    pending, running, status = list(names), [], 0
    while pending or running:
        while pending and len(running) < jobs:
            name = pending.pop(0)
            out = open(os.path.join(build_dir, 'run_tests_%s.out' % name[:150]), 'w+')
            # The target's own rule file: `cmake --build` would first check the whole build
            # system, seconds a test.
            target = '_' + PREFIX + name
            cmd = ['make', '-s', '-f', 'CMakeFiles/%s.dir/build.make' % target, target]
            running.append((name, subprocess.Popen(cmd, cwd=build_dir, stdout=out,
                                                   stderr=subprocess.STDOUT), out, time.time()))
        time.sleep(0.2)
        for item in list(running):
            name, proc, out, start = item
            if proc.poll() is None:
                continue
            running.remove(item)
            out.seek(0)
            log.write('==== %s: exit %d, %.0f s\n' % (name, proc.returncode, time.time() - start))
            log.write(out.read())
            log.flush()
            out.close()
            os.remove(out.name)
            status = status or proc.returncode
    return status


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('build_dir')
    ap.add_argument('log')
    ap.add_argument('--jobs', type=int, default=2)
    ap.add_argument('--list', action='store_true', help='print the two groups and run nothing')
    args = ap.parse_args()
    free, paced = groups(args.build_dir)
    if args.list:
        print('\n'.join(['%d at a time:' % args.jobs] + free + ['one at a time:'] + paced))
        return 0
    with open(args.log, 'a') as log:
        log.write('%d tests %d at a time, then %d on the wall clock one at a time\n'
                  % (len(free), args.jobs, len(paced)))
        first = run(args.build_dir, free, args.jobs, log)
        second = run(args.build_dir, paced, 1, log)
    return first or second


if __name__ == '__main__':
    sys.exit(main())
