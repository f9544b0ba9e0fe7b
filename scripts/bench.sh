#!/usr/bin/env bash
# `make bench`: runs every scripts/bench/*.sh (each prints its Markdown sections on stdout and its
# progress on stderr) under the topic headings of BENCHMARKS.md, with the machine they ran on, and
# writes the result to BENCHMARKS.md. The sections no script measures (the recorded UAH run,
# robustness, the tests' accuracy) are carried over from the BENCHMARKS.md it replaces.
set -euo pipefail
cd "$(dirname "$0")/.."
out=build/bench
mkdir -p "$out"
# kept HEADING: that section of the current BENCHMARKS.md, up to the next heading of its level or
# above (nothing when the file or the section is missing).
kept() {
  [ -f BENCHMARKS.md ] || return 0
  awk -v h="$1" '
    /^#+ / { level = index($0, " ") - 1; if (on && level <= depth) exit; if ($0 == h) { on = 1; depth = level } }
    on' BENCHMARKS.md
  echo
}
ran=" "
part() {
  echo "bench: $1" >&2
  bash "$1"
  echo
  ran="$ran$1 "
}
{
  echo "# autocal benchmarks"
  echo
  echo "Measured on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')),"
  echo "$(. /etc/os-release; echo "$PRETTY_NAME"). Ratios compare tools run side by side in the same run;"
  echo "absolute times move with the machine's load, the ratios less. \`make bench\` reproduces the sections"
  echo "it generates (it rewrites this file); each section names its own command. How the tests and"
  echo "benchmarks are organised: [doc/testing.md](doc/testing.md)."
  echo
  cat scripts/bench/README.part.md 2>/dev/null || true
  echo "## Camera"
  echo
  part scripts/bench/camera.sh
  part scripts/bench/camera_sweep.sh
  part scripts/bench/camera_uncertainty.sh
  echo "## Wheels"
  echo
  part scripts/bench/wheels.sh
  part scripts/bench/tags.sh
  echo "## Odometry"
  echo
  part scripts/bench/odometry.sh
  kept "### The recorded UAH run"
  echo "## Simulator and renderer"
  echo
  part scripts/bench/sim.sh
  part scripts/bench/fleet.sh
  # A script not placed above yet: under its own heading.
  others=""
  for p in scripts/bench/*.sh; do
    case "$ran" in *" $p "*) ;; *) others="$others $p" ;; esac
  done
  if [ -n "$others" ]; then
    echo "## Other benchmarks"
    echo
    for p in $others; do part "$p"; done
  fi
  kept "## Robustness"
  kept "## Accuracy in the tests"
} > "$out/BENCHMARKS.md.parts"
# One blank line between blocks, none at the end.
cat -s "$out/BENCHMARKS.md.parts" | sed -e :a -e '/^\n*$/{$d;N;ba' -e '}' > "$out/BENCHMARKS.md"
rm -f "$out/BENCHMARKS.md.parts"
cp "$out/BENCHMARKS.md" BENCHMARKS.md
echo "bench: wrote BENCHMARKS.md" >&2
