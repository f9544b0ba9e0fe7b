#!/bin/bash
# make demo: the simulated robot calibrates its camera by itself (see README "Demo"). Called by the
# Makefile with the devel space sourced. Output goes to ${DEMO_OUTPUT:-demo_output}; extra
# arguments go to roslaunch (e.g. real_time_factor:=1 robot_config:=FILE).
set -euo pipefail
out=$(realpath -m "${DEMO_OUTPUT:-demo_output}")
rm -rf "$out"
mkdir -p "$out"
# A private master on its own port, so that a running roscore is neither used nor disturbed.
port=${DEMO_ROS_PORT:-11385}
export ROS_MASTER_URI=http://localhost:$port
robot=$(rospack find autocal)/sim/config/robot.yaml
for arg in "$@"; do
  case $arg in robot_config:=*) robot=${arg#robot_config:=} ;; esac
done
roslaunch -p "$port" autocal demo.launch calibration_root:="$out/calibrations" "$@" \
  2>&1 | tee "$out/roslaunch.log" | grep --line-buffered -E "camera_calibration_node: (camera/|wrote|calibration failed)|FATAL" || true
yaml=$out/calibrations/camera_intrinsic/autobot.yaml
for arg in "$@"; do
  case $arg in veh:=*) yaml=$out/calibrations/camera_intrinsic/${arg#veh:=}.yaml ;; esac
done
test -s "$yaml" || { echo "demo: FAILED: no calibration written (see $out/roslaunch.log)" >&2; exit 1; }
echo
echo "The camera calibrated by the robot itself, against the simulator's true lens"
echo "(camera_info: the nominal model the robot started from):"
rosrun autocal compare_camera --robot-config "$robot" --calibration "$yaml"
echo
echo "demo: calibration in $yaml, its views in ${yaml%.yaml}_views/, the log in $out/roslaunch.log"
