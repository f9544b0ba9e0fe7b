#!/usr/bin/env bash
# make bench, odometry section: build/bench/odometry_bench (UAH and UMBmark driven by the robot on
# the simulator's core, four robot configs, against the truth; one core, under a minute).
# Markdown on stdout.
set -euo pipefail
cd "$(dirname "$0")/../.."
echo "bench/odometry: UAH and UMBmark on four simulated robots (under a minute)" >&2
taskset -c 0 build/bench/odometry_bench
