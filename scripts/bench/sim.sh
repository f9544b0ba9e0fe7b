#!/usr/bin/env bash
# make bench, simulator section: render ms/frame and real-time factors (stop-and-shoot sweep, straight
# drives, continuous driving; today's path beside the still-frame reuse) with and without the camera,
# pinned to one core. Prints Markdown on stdout.
set -euo pipefail
cd "$(dirname "$0")/../.."
echo "bench/sim: rendering and stepping, today's path beside the still-frame reuse (about five minutes)" >&2
taskset -c 0 build/bench/sim_bench sim/config/robot.yaml sim/config/world.yaml "${SIM_BENCH_SECONDS:-60}"
echo
echo "Reproduce: \`make build && taskset -c 0 build/bench/sim_bench sim/config/robot.yaml sim/config/world.yaml 60\`."
