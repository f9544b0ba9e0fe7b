#!/usr/bin/env bash
# `make bench`: runs every scripts/bench/*.sh (each prints its Markdown sections on stdout and its
# progress on stderr) and puts what they print into BENCHMARKS.md with scripts/bench_merge.py:
# each measured section replaces its block between "<!-- make bench: ... -->" markers, and
# everything outside the blocks (the analysis of the figures, runs made by hand, robustness, the
# tests' accuracy) is kept. A script that fails stops the run before BENCHMARKS.md is touched.
set -euo pipefail
cd "$(dirname "$0")/.."
parts=build/bench/parts
rm -rf "$parts"
mkdir -p "$parts"
# The scripts of each topic, in the order of their sections.
topics=(
  "Camera=camera.sh,camera_sweep.sh,camera_uncertainty.sh"
  "Wheels=wheels.sh,tags.sh"
  "Odometry=odometry.sh"
  "Simulator and renderer=sim.sh,fleet.sh"
)
placed=","
for t in "${topics[@]}"; do placed="$placed${t#*=},"; done
# A script no topic names: under "Other benchmarks".
others=""
for p in scripts/bench/*.sh; do
  case "$placed" in *",$(basename "$p"),"*) ;; *) others="$others,$(basename "$p")" ;; esac
done
[ -n "$others" ] && topics+=("Other benchmarks=${others#,}")
for t in "${topics[@]}"; do
  IFS=, read -ra names <<< "${t#*=}"
  for name in "${names[@]}"; do
    echo "bench: scripts/bench/$name" >&2
    bash "scripts/bench/$name" > "$parts/${name%.sh}.md"
  done
done
{
  echo "Measured on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')),"
  echo "$(. /etc/os-release; echo "$PRETTY_NAME"). Ratios compare tools run side by side in the same run;"
  echo "absolute times move with the machine's load, the ratios less. \`make bench\` measures again the"
  echo "sections between \"make bench\" markers (see the Markdown source) and leaves the rest as it is;"
  echo "each section names its own command. How the tests and benchmarks are organised:"
  echo "[doc/testing.md](doc/testing.md)."
} > "$parts/machine.md"
/usr/bin/python3 scripts/bench_merge.py BENCHMARKS.md "$parts" "${topics[@]}"
echo "bench: wrote BENCHMARKS.md" >&2
