#!/usr/bin/env bash
# make bench, wheel stage section: build/bench/wheel_bench (the wheel stage on the simulator's core
# over six robot configs, autocal vs the paper alone; one core, about 3 minutes). Markdown on stdout.
set -euo pipefail
cd "$(dirname "$0")/../.."
echo "bench/wheels: twelve wheel calibrations on the simulator's core (about 3 minutes)" >&2
taskset -c 0 build/bench/wheel_bench
