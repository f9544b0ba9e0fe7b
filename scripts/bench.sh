#!/usr/bin/env bash
# `make bench`: runs every scripts/bench/*.sh (each prints one Markdown section on stdout and its
# progress on stderr) and writes the sections, with the machine they ran on, to BENCHMARKS.md.
set -euo pipefail
cd "$(dirname "$0")/.."
out=build/bench
mkdir -p "$out"
{
  echo "# autocal benchmarks"
  echo
  echo "Written by \`make bench\` on $(date -u +%Y-%m-%d) — $(nproc) cores," \
       "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(. /etc/os-release; echo "$PRETTY_NAME")."
  echo "Every figure below is measured in the same run; ratios compare tools run side by side."
  echo "Reproduce with \`make bench\` (single-threaded where a section says so)."
  echo
  cat scripts/bench/README.part.md 2>/dev/null || true
} > "$out/BENCHMARKS.md"
for part in scripts/bench/*.sh; do
  echo "bench: $part" >&2
  "$part" >> "$out/BENCHMARKS.md"
  echo >> "$out/BENCHMARKS.md"
done
cp "$out/BENCHMARKS.md" BENCHMARKS.md
echo "bench: wrote BENCHMARKS.md" >&2
