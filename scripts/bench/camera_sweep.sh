#!/usr/bin/env bash
# make bench, the camera stage's sweep: the camera stage over the fleet's robot configs on the
# simulator's core (one core), then the ROS node end to end in the simulator at
# real_time_factor 0. Prints Markdown on stdout.
set -euo pipefail
cd "$(dirname "$0")/../.."
echo "bench/camera_sweep: five sweeps on the simulator's core, then the node under ROS (about two minutes)" >&2
sweeps=$(mktemp)
taskset -c 0 build/bench/camera_sweep_bench > "$sweeps"
# The sweeps' table and its notes first, then the bench's honesty section (its own heading).
honesty='^#### Is the predicted uncertainty honest'
awk -v h="$honesty" '$0 ~ h { exit } { print }' "$sweeps"
cat <<'NOTE'

Plain OpenCV from its own closed-form start lands in a wrong minimum on most sweeps (views all at
one height in the image); from `camera_info`'s camera matrix, as autocal starts, it agrees with
autocal, which fits the same sharp views. Fitting only the views kept for coverage (last plain
column) is worse: the fit needs every sharp view.
NOTE
echo
root=$(mktemp -d)
port=11397
robot=sim/config/robot.yaml  # the launch's default robot, named so that its truth is read below
start=$(date +%s.%N)
ROS_MASTER_URI=http://localhost:$port roslaunch -p $port autocal camera_sim.launch \
  calibration_root:="$root" robot_config:="$PWD/$robot" real_time_factor:=0 \
  > "$root/roslaunch.log" 2>&1 || true
end=$(date +%s.%N)
line=$(grep -a "camera_calibration_node: wrote" "$root/roslaunch.log" | sed 's/.*camera_calibration_node: //; s/\x1b\[[0-9;]*m//g' || true)
# "wrote FILE: fx .. fy .. cx .. cy .. k1 .., RMS .. px over N views (...), sweep .. s" -> the figures.
found=$(printf '%s\n' "$line" | sed -n 's/^wrote [^:]*: fx \([-0-9.]*\) fy \([-0-9.]*\) cx \([-0-9.]*\) cy \([-0-9.]*\) k1 \([-0-9.]*\), RMS \([0-9.]*\) px over \([0-9]*\) views.*/fx \1, fy \2, cx \3, cy \4, k1 \5 (truth TRUTH), RMS \6 px over \7 views/p' | head -1)
truth=$(/usr/bin/python3 -c 'import sys, yaml; c = yaml.safe_load(open(sys.argv[1]))["camera"]; print("%s, %s, %s, %s, %s" % (c["fx"], c["fy"], c["cx"], c["cy"], c["distortion_coefficients"][0]))' "$robot" 2>/dev/null || true)
# Over the whole image against the true lens, as the tests judge it.
written=$(ls "$root"/camera_intrinsic/*.yaml 2>/dev/null | head -1 || true)
whole=""
if [ -n "$written" ]; then
  model=$(/usr/bin/python3 -c 'import sys, yaml; print(yaml.safe_load(open(sys.argv[1]))["distortion_model"])' "$written" 2>/dev/null || true)
  whole=$(build/devel/lib/autocal/compare_camera --robot-config "$robot" --calibration "$written" 2>/dev/null |
    sed -n 's/^projection difference over the whole image[^:]*: RMS \([0-9.]*\) px, worst \([0-9.]*\) px.*/\1 px RMS, worst pixel \2 px/p' || true)
  if [ -n "$whole" ]; then
    whole="; $model written, its projection difference over the whole image $whole"
  fi
fi
if [ -n "$found" ] && [ -n "$truth" ]; then
  result=${found/TRUTH/$truth}$whole
elif [ -n "$line" ]; then
  result="the node: $line"
else
  result="no calibration written, see the log"
fi
echo "The ROS node end to end (\`roslaunch autocal camera_sim.launch real_time_factor:=0\`, default robot"
echo "(\`$robot\`, an equidistant lens) and world, both cores, including roslaunch's start): $(awk "BEGIN { printf \"%.1f\", $end - $start }") s of wall time;"
echo "$result. The sweep's simulated length at real_time_factor 0 depends on how promptly the node is"
echo "scheduled (the simulator does not wait for it), so the camera rostests run at real_time_factor 5."
echo
echo "Reproduce: \`bash scripts/bench/camera_sweep.sh\` after \`make build\` (the sweeps alone:"
echo "\`taskset -c 0 build/bench/camera_sweep_bench\`; the node: \`roslaunch autocal camera_sim.launch"
echo "calibration_root:=/tmp/cal real_time_factor:=0\` with the devel space sourced)."
echo
awk -v h="$honesty" '$0 ~ h { on = 1 } on' "$sweeps"
rm -rf "$root" "$sweeps"
