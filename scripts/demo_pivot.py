#!/usr/bin/env python3
"""The simulator demo scenario (make demo): the robot pivots on one stopped wheel in front of the
chessboards, in steps, stopping before each shot (stop-and-shoot, paper 000 section 4), first
clockwise about its right wheel, then counter-clockwise about its left wheel. It saves the frame
taken at each stop and the whole trajectory (ground truth and encoder ticks) to ~output_dir.

This is a demo driver, not a calibration node: it reads the simulator's ground truth to report how
still the stopped wheel's contact point stayed.

Private parameters (defaults):
  ~output_dir (demo_output)   where frames/, trajectory.csv and summary.yaml go
  ~duty (0.25)                duty of the turning wheel
  ~turn_s (0.25)              time the wheel turns per step [s of sim time]
  ~settle_s (0.6)             time standing still before a shot [s]
  ~steps_cw (4), ~steps_ccw (8)
  ~robot_config               the sim's robot YAML (for the wheelbase; default: the package's)
Topics (relative to the node's namespace): publishes wheels_driver_node/wheels_cmd; subscribes
camera_node/image/compressed, sim/ground_truth, left/right_wheel_encoder_node/tick.
"""
import math
import os
import sys

import rospy
import yaml
from autocal.msg import WheelEncoderStamped, WheelsCmdStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CompressedImage


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class Demo:
    def __init__(self):
        self.output_dir = os.path.abspath(rospy.get_param("~output_dir", "demo_output"))
        self.duty = float(rospy.get_param("~duty", 0.25))
        self.turn_s = float(rospy.get_param("~turn_s", 0.25))
        self.settle_s = float(rospy.get_param("~settle_s", 0.6))
        self.steps_cw = int(rospy.get_param("~steps_cw", 4))
        self.steps_ccw = int(rospy.get_param("~steps_ccw", 8))
        robot_config = rospy.get_param("~robot_config", os.path.join(
            os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sim", "config", "robot.yaml"))
        with open(robot_config) as f:
            self.wheelbase_m = float(yaml.safe_load(f)["wheelbase"])
        os.makedirs(os.path.join(self.output_dir, "frames"), exist_ok=True)

        self.cmd = (0.0, 0.0)
        self.phase = "wait"
        self.ticks = [0, 0]
        self.rows = []
        self.last_image = None
        self.pub = rospy.Publisher("wheels_driver_node/wheels_cmd", WheelsCmdStamped, queue_size=10)
        rospy.Subscriber("sim/ground_truth", Odometry, self.on_truth, queue_size=100)
        rospy.Subscriber("left_wheel_encoder_node/tick", WheelEncoderStamped, self.on_tick, 0, queue_size=100)
        rospy.Subscriber("right_wheel_encoder_node/tick", WheelEncoderStamped, self.on_tick, 1, queue_size=100)
        rospy.Subscriber("camera_node/image/compressed", CompressedImage, self.on_image, queue_size=5)

    def on_tick(self, msg, side):
        self.ticks[side] = msg.data

    def on_truth(self, msg):
        p = msg.pose.pose
        self.rows.append((msg.header.stamp.to_sec(), p.position.x, p.position.y, yaw_of(p.orientation),
                          self.ticks[0], self.ticks[1], self.cmd[0], self.cmd[1], self.phase))

    def on_image(self, msg):
        self.last_image = msg

    def publish(self, left, right):
        self.cmd = (left, right)
        msg = WheelsCmdStamped()
        msg.header.stamp = rospy.Time.now()
        msg.vel_left, msg.vel_right = left, right
        self.pub.publish(msg)

    def hold(self, left, right, duration_s):
        """Publishes the duty at 20 Hz (the sim's watchdog wants one within 0.5 s) for duration_s."""
        end = rospy.get_time() + duration_s
        while not rospy.is_shutdown() and rospy.get_time() < end:
            self.publish(left, right)
            rospy.sleep(0.05)

    def shoot(self, index):
        """Saves the first frame exposed after the robot came to rest."""
        rest = rospy.Time.now()
        deadline = rospy.get_time() + 2.0
        while not rospy.is_shutdown() and rospy.get_time() < deadline:
            image = self.last_image
            if image is not None and image.header.stamp >= rest:
                path = os.path.join(self.output_dir, "frames", "frame_%02d.jpg" % index)
                with open(path, "wb") as f:
                    f.write(bytes(image.data))
                return path
            self.publish(0.0, 0.0)
            rospy.sleep(0.02)
        raise RuntimeError("no camera frame within 2 s of sim time: is the simulator's camera on?")

    def contact_drift_m(self, phase, side):
        """How far the stopped wheel's contact point moved during a phase (ground truth)."""
        offset = 0.5 * self.wheelbase_m * (1.0 if side == "left" else -1.0)
        points = [(x - offset * math.sin(yaw), y + offset * math.cos(yaw))
                  for (_, x, y, yaw, *_rest) in [r for r in self.rows if r[8] == phase]]
        if not points:
            return float("nan")
        return max(math.hypot(px - points[0][0], py - points[0][1]) for px, py in points)

    def run(self):
        while not rospy.is_shutdown() and (rospy.get_time() < 1.0 or not self.rows):
            rospy.sleep(0.05)
        self.hold(0.0, 0.0, 0.5)
        frames = [self.shoot(0)]
        plan = [("pivot_cw_on_right_wheel", self.duty, 0.0, self.steps_cw),
                ("pivot_ccw_on_left_wheel", 0.0, self.duty, self.steps_ccw)]
        for phase, left, right, steps in plan:
            self.phase = phase
            for _ in range(steps):
                self.hold(left, right, self.turn_s)
                self.hold(0.0, 0.0, self.settle_s)
                frames.append(self.shoot(len(frames)))
                rospy.loginfo("demo: %s, frame %d, yaw %.1f deg", phase, len(frames) - 1,
                              math.degrees(self.rows[-1][3]))
        self.phase = "done"
        self.hold(0.0, 0.0, 0.3)

        with open(os.path.join(self.output_dir, "trajectory.csv"), "w") as f:
            f.write("t_s,x_m,y_m,yaw_rad,left_ticks,right_ticks,duty_left,duty_right,phase\n")
            for r in self.rows:
                f.write("%.3f,%.6f,%.6f,%.6f,%d,%d,%.3f,%.3f,%s\n" % r)
        drift_right = self.contact_drift_m("pivot_cw_on_right_wheel", "right")
        drift_left = self.contact_drift_m("pivot_ccw_on_left_wheel", "left")
        summary = {
            "frames": len(frames),
            "trajectory_samples": len(self.rows),
            "sim_time_s": round(rospy.get_time(), 3),
            "stopped_right_wheel_contact_drift_mm": round(1000 * drift_right, 3),
            "stopped_left_wheel_contact_drift_mm": round(1000 * drift_left, 3),
            "final_yaw_deg": round(math.degrees(self.rows[-1][3]), 2),
        }
        with open(os.path.join(self.output_dir, "summary.yaml"), "w") as f:
            yaml.safe_dump(summary, f, sort_keys=False)
        rospy.loginfo("demo: wrote %d frames, %d trajectory samples to %s", len(frames), len(self.rows),
                      self.output_dir)
        print(yaml.safe_dump(summary, sort_keys=False), end="")
        return 0


def main():
    rospy.init_node("demo_pivot")
    try:
        return Demo().run()
    except (RuntimeError, OSError, KeyError, ValueError) as e:
        rospy.logfatal("demo: %s", e)
        return 1
    except rospy.ROSInterruptException:
        return 1


if __name__ == "__main__":
    sys.exit(main())
