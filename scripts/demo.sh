#!/bin/bash
# make demo: runs the main job in the simulator (see README "Demo"). Called by the Makefile with
# the devel space sourced. Output goes to ${DEMO_OUTPUT:-demo_output}.
set -euo pipefail
out=$(realpath -m "${DEMO_OUTPUT:-demo_output}")
rm -rf "$out"
mkdir -p "$out"
# A private master on its own port, so that a running roscore is neither used nor disturbed.
port=${DEMO_ROS_PORT:-11385}
export ROS_MASTER_URI=http://localhost:$port
roslaunch -p "$port" autocal demo.launch output_dir:="$out" "$@"
test -s "$out/trajectory.csv" || { echo "demo: FAILED: no trajectory written" >&2; exit 1; }
echo "demo: frames in $out/frames, trajectory in $out/trajectory.csv, summary in $out/summary.yaml"
