#!/usr/bin/python3
"""`make robustness`: the whole calibration in robot mode over a matrix of simulated robots.

Draws N robots (seeded) from sim/config/robot.yaml (the realistic default robot): a wide-angle
(equidistant) lens whose plumb_bob fit lands within the real fleet's ranges (fx 309-352 px, which
Duckietown's plumb_bob calibrations see as 317-361; cx 300-336, cy 210-256; k1 -0.01..0.05, k2
-0.03..0.01), a trim within -0.09..+0.08 (motor gains and wheel radii), a deadband, breakaway
duties, backward gains, a gain drift, gearbox backlash and wheel slip within their documented
ranges, and the transport of robot.yaml. Each robot's room is world_full.yaml (world.yaml with
--no-odometry) lit by a light gradient (world YAML `light_gradient`, up to 0.1 per metre along each
axis), its floor tags laid as a person lays them (world YAML `floor_tag_placement`: sigma 1-4 mm
and 0.6-2 deg). Each robot runs `rosrun autocal calibrate_sim odometry:=true` (camera, wheel and
UAH stages; --no-odometry: the first two) at each real-time factor given (1: a robot's own
computer; 3: one three times slower), on its own master. From the simulator's truth (compare_camera,
compare_wheels, compare_extrinsics, the odometry file against the robot's radii and wheelbase) it
reports per run the result and reason, fx/fy error, the whole-image projection difference, the
trim error, the drift over 2 m, the errors of Ed and the wheelbase, and the ground projection's
error (floor points 0.1-0.6 m ahead; the camera's height, pitch, roll and yaw), and prints
Markdown tables with the distributions (median, 95th percentile, worst) for BENCHMARKS.md.

    /usr/bin/python3 scripts/robustness.py [--robots 20] [--rtf 1 3] [--seed 1] [--no-odometry]
                                           [--jobs 1] [--first 1] [--out build/robustness]
                                           [--table-only]

--jobs N runs N robots at once, each on its own master (on 2 cores, two runs at factor 1 give each
about as much of the machine as one run at factor 2). Every finished run is appended to
OUT/runs.jsonl; --first K starts at robot K (to go on with a matrix), and --table-only prints the
tables from the runs in OUT/runs.jsonl for the seed without running anything.

Needs `make build` and the devel space sourced (the Makefile's robustness target does both).
"""
import argparse
import concurrent.futures
import json
import os
import random
import re
import statistics
import subprocess
import sys
import time

import yaml

PKG = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))


def draw_robot(base, rng):
    """A robot of the real fleet's kind: base (robot.yaml) with drawn values."""
    r = yaml.safe_load(yaml.safe_dump(base))
    cam = r["camera"]
    # A wide-angle lens, rendered as the equidistant (fisheye) model a Duckiebot's is. Fitted as
    # plumb_bob, as Duckietown's calibrations are, an equidistant fx f gives about 1.026 f
    # (robot.yaml's lens: 300 -> 307.7): the fleet's plumb_bob fx 317-361 are equidistant fx
    # 309-352. The principal point is within the fleet's ranges; k1 and k2 around robot.yaml's.
    cam["fx"] = round(rng.uniform(309, 352), 2)
    cam["fy"] = round(cam["fx"] * rng.uniform(0.995, 1.015), 2)
    cam["cx"] = round(rng.uniform(300, 336), 2)
    cam["cy"] = round(rng.uniform(210, 256), 2)
    cam["distortion_model"] = "equidistant"
    cam["distortion_coefficients"] = [round(rng.uniform(-0.01, 0.05), 4),
                                      round(rng.uniform(-0.03, 0.01), 4), 0.0, 0.0]
    # A trim t makes right/left = k = (1 + t) / (1 - t) at gain 1; the wheels' radii differ a
    # little, the motors' gains make up the rest.
    trim = rng.uniform(-0.09, 0.08)
    k = (1 + trim) / (1 - trim)
    r["wheel_radius_left"] = round(0.0318 * rng.uniform(0.99, 1.01), 5)
    r["wheel_radius_right"] = round(0.0318 * rng.uniform(0.99, 1.01), 5)
    r["motor_gain_left"] = 1.0
    r["motor_gain_right"] = round(r["wheel_radius_left"] / (k * r["wheel_radius_right"]), 5)
    r["wheelbase"] = round(rng.uniform(0.098, 0.106), 4)
    r["deadband"] = round(rng.uniform(0.05, 0.11), 3)
    r["breakaway_duty_left"] = round(r["deadband"] + rng.uniform(0.0, 0.04), 3)
    r["breakaway_duty_right"] = round(r["deadband"] + rng.uniform(0.0, 0.04), 3)
    r["backward_gain_ratio_left"] = round(rng.uniform(0.95, 1.05), 3)
    r["backward_gain_ratio_right"] = round(rng.uniform(0.95, 1.05), 3)
    r["gain_drift_per_min"] = round(rng.uniform(-0.01, 0.0), 4)
    r["backlash_rad"] = round(rng.uniform(0.0, 0.06), 3)
    r["wheel_slip_sigma"] = round(rng.uniform(0.0, 0.003), 4)
    return r


def draw_world(base, rng):
    """The whole run's world (base: world_full.yaml or world.yaml) lit unevenly: a light gradient
    of up to 0.1 per metre along each axis (about 1.4 between the ends of world_full's room and
    corridor)."""
    w = yaml.safe_load(yaml.safe_dump(base))
    w["light_gradient"] = {"x_per_m": round(rng.uniform(-0.1, 0.1), 3),
                           "y_per_m": round(rng.uniform(-0.1, 0.1), 3)}
    return w


def draw_tag_placement(world, rng):
    """The floor tags as a person lays them (world YAML `floor_tag_placement`): each off its place
    by a few millimetres and turned by a degree or two (sigma 1-4 mm, 0.6-2 deg), drawn from a
    generator of its own so that the other draws stay those of the same seed."""
    world["floor_tag_placement"] = {"position_sigma_m": round(rng.uniform(0.001, 0.004), 4),
                                    "yaw_sigma_rad": round(rng.uniform(0.01, 0.035), 4),
                                    "seed": rng.randrange(1, 10000)}
    return world


def figures(pattern, text):
    m = re.search(pattern, text, re.M)
    return [float(x) for x in m.groups()] if m else None


def judge(robot_file, root, veh):
    """The run's files against the truth: a dict of figures (missing ones absent)."""
    out = {}
    odometry = os.path.join(root, "odometry", veh + ".yaml")
    if os.path.isfile(odometry):
        # UAH's Ed = c_R / c_L (the wheels' radii) and the wheelbase, against the robot's truth.
        with open(robot_file) as f:
            robot = yaml.safe_load(f)
        with open(odometry) as f:
            o = yaml.safe_load(f)
        true_ed = robot["wheel_radius_right"] / robot["wheel_radius_left"]
        out["ed_pct"] = abs(100 * (o["Ed"] / true_ed - 1))
        out["wheelbase_pct"] = abs(100 * (o["b"] / robot["wheelbase"] - 1))
    camera = os.path.join(root, "camera_intrinsic", veh + ".yaml")
    kinematics = os.path.join(root, "kinematics", veh + ".yaml")
    if os.path.isfile(camera):
        text = subprocess.run(["rosrun", "autocal", "compare_camera", "--robot-config", robot_file,
                               "--calibration", camera], stdout=subprocess.PIPE, text=True).stdout
        fx = figures(r"^fx\s+\S+\s+\S+\s+\S+\s+([-+0-9.]+)%", text)
        fy = figures(r"^fy\s+\S+\s+\S+\s+\S+\s+([-+0-9.]+)%", text)
        pd = figures(r"RMS ([0-9.]+) px, worst ([0-9.]+) px; upper half ([0-9.]+) px, "
                     r"lower half ([0-9.]+) px", text)
        if fx and fy and pd:
            out.update(fx_pct=abs(fx[0]), fy_pct=abs(fy[0]), proj_rms_px=pd[0],
                       proj_worst_px=pd[1], proj_lower_px=pd[3])
    if os.path.isfile(kinematics):
        text = subprocess.run(["rosrun", "autocal", "compare_wheels", "--robot-config", robot_file,
                               "--calibration", kinematics], stdout=subprocess.PIPE,
                              text=True).stdout
        trim = figures(r"^trim\s+\S+\s+\S+\s+\S+\s+([-+0-9.]+)", text)
        if trim:
            out["trim_err"] = abs(trim[0])
        for v in ("0.15", "0.25", "0.40"):
            m = re.search(r"drift over 2 m at %s m/s: before \S+ cm, calibrated (\S+) cm" % v,
                          text)
            if m:  # nan: the robot never came 2 m along the line (it turned away or stalled)
                d = float(m.group(1))
                out["drift_%s_cm" % v] = float("inf") if d != d else d
    extrinsics = os.path.join(root, "camera_extrinsic", veh + ".yaml")
    if os.path.isfile(extrinsics) and os.path.isfile(camera):
        text = subprocess.run(["rosrun", "autocal", "compare_extrinsics", "--robot-config",
                               robot_file, "--calibration", extrinsics, "--camera-info", camera],
                              stdout=subprocess.PIPE, text=True).stdout
        ground = figures(r"ground projection: ([0-9.]+) mm RMS, ([0-9.]+) mm worst", text)
        if ground:
            out.update(ground_rms_mm=ground[0], ground_worst_mm=ground[1])
        for key, label in (("height_mm", "height \\[mm\\]"), ("pitch_deg", "pitch \\[deg\\]"),
                           ("roll_deg", "roll \\[deg\\]"), ("yaw_deg", "yaw \\[deg\\]")):
            e = figures(r"^%s\s+\S+\s+\S+\s+([-+0-9.]+)" % label, text)
            if e:
                out[key] = abs(e[0])
    return out


def run_one(robot_file, world_file, veh, rtf, root, port, odometry):
    env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % port)
    cmd = ["rosrun", "autocal", "calibrate_sim", "veh:=" + veh, "robot_config:=" + robot_file,
           "world_config:=" + world_file, "real_time_factor:=%g" % rtf, "calibration_root:=" + root,
           "odometry:=" + ("true" if odometry else "false")]
    start = time.time()
    with open(os.path.join(root + ".log"), "w") as log:
        proc = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, timeout=3600)
    wall_s = time.time() - start
    result, failure = "no summary", ""
    summary = os.path.join(root, "report", veh, "summary.yaml")
    if os.path.isfile(summary):
        with open(summary) as f:
            s = yaml.safe_load(f)
        result, failure = s.get("result", "?"), s.get("failure", "")
    return dict(rc=proc.returncode, result=result, failure=failure, wall_s=wall_s)


def distribution(values):
    if not values:
        return "-"
    v = sorted(values)
    p95 = v[min(len(v) - 1, int(round(0.95 * (len(v) - 1))))]
    return "%.3g / %.3g / %.3g" % (statistics.median(v), p95, v[-1])


def write_draws(i, a, base, base_world):
    """Robot i and its room, drawn from the seed, as files: their paths."""
    robot_file = os.path.join(a.out, "robot%d.yaml" % i)
    with open(robot_file, "w") as f:
        yaml.safe_dump(draw_robot(base, random.Random(a.seed * 1000 + i)), f, sort_keys=False)
    world_file = os.path.join(a.out, "world%d.yaml" % i)
    with open(world_file, "w") as f:
        world = draw_world(base_world, random.Random(a.seed * 1000 + 500 + i))
        yaml.safe_dump(draw_tag_placement(world, random.Random(a.seed * 1000 + 700 + i)), f,
                       sort_keys=False)
    return robot_file, world_file


def run_robot(i, rtf, a, robot_file, world_file):
    """Robot i at real-time factor rtf: the run's row."""
    veh = "robot%d" % i
    root = os.path.join(a.out, "rtf%g" % rtf, veh)
    subprocess.run(["rm", "-rf", root])
    os.makedirs(root)
    port = 11700 + 10 * i + a.rtf.index(rtf)
    r = run_one(robot_file, world_file, veh, rtf, root, port, a.odometry)
    r.update(judge(robot_file, root, veh), robot=veh, rtf=rtf, seed=a.seed)
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robots", type=int, default=20)
    ap.add_argument("--rtf", type=float, nargs="+", default=[1.0, 3.0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-odometry", dest="odometry", action="store_false",
                    help="camera and wheel stages only (no UAH stage)")
    ap.add_argument("--out", default=os.path.join(PKG, "build", "robustness"))
    ap.add_argument("--jobs", type=int, default=1, help="robots run at once")
    ap.add_argument("--first", type=int, default=1, help="the first robot to run")
    ap.add_argument("--table-only", action="store_true",
                    help="print the tables from OUT/runs.jsonl; run nothing")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(PKG, "sim", "config", "robot.yaml")) as f:
        base = yaml.safe_load(f)
    world_name = "world_full.yaml" if a.odometry else "world.yaml"
    with open(os.path.join(PKG, "sim", "config", world_name)) as f:
        base_world = yaml.safe_load(f)
    rows_file = os.path.join(a.out, "runs.jsonl")
    if a.table_only:
        with open(rows_file) as f:
            rows = [r for r in map(json.loads, f) if r.get("seed") == a.seed and r["rtf"] in a.rtf]
    else:
        rows = []
        # Each robot's files are written once, before any of its runs starts.
        draws = {i: write_draws(i, a, base, base_world) for i in range(a.first, a.robots + 1)}
        with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
            futures = [pool.submit(run_robot, i, rtf, a, *draws[i]) for i in draws for rtf in a.rtf]
            for future in concurrent.futures.as_completed(futures):
                r = future.result()
                rows.append(r)
                with open(rows_file, "a") as f:
                    f.write(json.dumps(r) + "\n")
                shown = {k: v for k, v in r.items()
                         if k.endswith(("pct", "px", "err", "cm", "mm", "deg"))}
                print("%s rtf %g: %s %s (%.0f s) %s" % (r["robot"], r["rtf"], r["result"],
                                                         r["failure"], r["wall_s"], shown),
                      file=sys.stderr, flush=True)
    robots = len({r["robot"] for r in rows})
    print("## Robustness: the whole calibration in robot mode\n")
    print("%d robots drawn from `sim/config/robot.yaml`, each in `%s` with a light gradient, with "
          "seed %d (`/usr/bin/python3 "
          "scripts/robustness.py --robots %d --seed %d`); per real-time factor: runs that "
          "succeeded, then median / 95th percentile / worst.\n" % (robots, world_name, a.seed,
                                                                  a.robots, a.seed))
    keys = [("fx_pct", "fx error %"), ("fy_pct", "fy error %"),
            ("proj_rms_px", "projection RMS px"), ("proj_worst_px", "projection worst px"),
            ("proj_lower_px", "lower half RMS px"), ("trim_err", "trim error"),
            ("drift_0.15_cm", "drift 0.15 m/s cm"), ("drift_0.25_cm", "drift 0.25 m/s cm"),
            ("drift_0.40_cm", "drift 0.4 m/s cm"), ("ed_pct", "Ed error %"),
            ("wheelbase_pct", "wheelbase error %"), ("ground_rms_mm", "ground RMS mm"),
            ("ground_worst_mm", "ground worst mm"), ("height_mm", "camera height mm"),
            ("pitch_deg", "pitch deg"), ("roll_deg", "roll deg"), ("yaw_deg", "yaw deg"),
            ("wall_s", "wall s")]
    print("| real-time factor | succeeded | " + " | ".join(k[1] for k in keys) + " |")
    print("|---" * (len(keys) + 2) + "|")
    for rtf in a.rtf:
        runs = [r for r in rows if r["rtf"] == rtf]
        ok = [r for r in runs if r["result"] == "success"]
        cells = [distribution([r[k] for r in ok if k in r]) for k, _ in keys]
        print("| %g | %d of %d | %s |" % (rtf, len(ok), len(runs), " | ".join(cells)))
    failed = [r for r in rows if r["result"] != "success"]
    if failed:
        print("\nFailures:\n")
        for r in failed:
            print("* %s at %g: %s" % (r["robot"], r["rtf"], r["failure"] or r["result"]))


if __name__ == "__main__":
    main()
