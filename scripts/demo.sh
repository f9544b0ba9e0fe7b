#!/bin/bash
# make demo: the simulated robot calibrates its camera and its wheels by itself (README "Two commands").
# Called by the Makefile with the devel space sourced. Output goes to ${DEMO_OUTPUT:-demo_output};
# extra arguments go to roslaunch (e.g. real_time_factor:=1 robot_config:=FILE veh:=NAME).
set -euo pipefail
out=$(realpath -m "${DEMO_OUTPUT:-demo_output}")
rm -rf "$out"
mkdir -p "$out"
# A private master on its own port, so that a running roscore is neither used nor disturbed.
port=${DEMO_ROS_PORT:-11385}
export ROS_MASTER_URI=http://localhost:$port
robot=$(rospack find autocal)/sim/config/robot.yaml
veh=autobot
for arg in "$@"; do
  case $arg in
    robot_config:=*) robot=${arg#robot_config:=} ;;
    veh:=*) veh=${arg#veh:=} ;;
  esac
done
cal=$out/calibrations
echo "demo: the camera stage, then the wheel stage, in the simulator (about 2 minutes)"
roslaunch -p "$port" autocal demo.launch calibration_root:="$cal" "$@" \
  2>&1 | tee "$out/roslaunch.log" | grep --line-buffered -E \
  "run_report_node: |FATAL" || true
camera=$cal/camera_intrinsic/$veh.yaml
kinematics=$cal/kinematics/$veh.yaml
grep -q '^result: success$' "$cal/report/$veh/summary.yaml" 2>/dev/null ||
  { echo "demo: FAILED: the run did not succeed (see $cal/report/$veh/summary.yaml and $out/roslaunch.log)" >&2; exit 1; }
test -s "$camera" || { echo "demo: FAILED: no camera calibration written (see $out/roslaunch.log)" >&2; exit 1; }
test -s "$kinematics" || { echo "demo: FAILED: no wheel calibration written (see $out/roslaunch.log)" >&2; exit 1; }

echo
echo "The camera calibrated by the robot itself, against the simulator's true lens"
echo "(camera_info: the nominal model the robot started from):"
rosrun autocal compare_camera --robot-config "$robot" --calibration "$camera"
echo
echo "The wheels calibrated by the robot itself (before: no kinematics file, Duckietown's defaults),"
echo "against what the simulated robot's true wheels need:"
rosrun autocal compare_wheels --robot-config "$robot" --calibration "$kinematics"
extrinsics=$cal/camera_extrinsic/$veh.yaml
if test -s "$extrinsics"; then
  echo
  echo "The camera's ground projection (extrinsics) found by the robot itself from the floor tags,"
  echo "against the simulator's true camera mount:"
  rosrun autocal compare_extrinsics --robot-config "$robot" --calibration "$extrinsics" \
    --camera-info "$camera"
else
  echo "demo: no camera extrinsics written (see the wheel stage in $out/roslaunch.log)"
fi

# Duckietown's acceptance test, on an empty floor, before (defaults) and after (the calibration).
echo
echo "validate_straight: 2 m straight through the kinematics node, drift from the simulator's truth"
mkdir -p "$out/before"
for which in before after; do
  root=$cal
  [ "$which" = before ] && root=$out/before
  roslaunch -p "$port" autocal validate_straight_sim.launch veh:="$veh" robot_config:="$robot" \
    calibration_root:="$root" fail_above_max_drift:=false result_file:="$out/validate_$which.yaml" \
    > "$out/validate_$which.log" 2>&1 || true
  test -s "$out/validate_$which.yaml" ||
    { echo "demo: FAILED: validate_straight ($which) wrote nothing (see $out/validate_$which.log)" >&2; exit 1; }
done
printf "%-10s %16s %16s\n" "speed" "drift before" "drift after"
paste <(grep -o 'speed_mps: [^,]*, drift_m: [^,]*, [^,]*, reached: [a-z]*' "$out/validate_before.yaml") \
      <(grep -o 'drift_m: [^,]*, [^,]*, reached: [a-z]*' "$out/validate_after.yaml") |
  awk -F'[:,\t]' '{
    b = ($8 ~ /true/) ? sprintf("%.1f cm", 100 * $4) : "turned away";
    a = ($14 ~ /true/) ? sprintf("%.1f cm", 100 * $10) : "turned away";
    printf "%-10s %16s %16s\n", sprintf("%.2f m/s", $2), b, a }'
echo "(Duckietown accepts 10 cm over 2 m.)"
echo
echo "demo: calibrations in $cal (camera_intrinsic/$veh.yaml and its views, kinematics/$veh.yaml,"
echo "      camera_extrinsic/$veh.yaml),"
echo "      the run's report in $cal/report/$veh (report.png, summary.yaml), logs in $out"
