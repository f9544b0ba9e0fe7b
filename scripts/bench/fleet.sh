#!/usr/bin/env bash
# make bench, fleet section: sim_fleet.launch with 1, 2, 4 and 8 robots at real_time_factor 0 (as
# fast as the machine allows, every node on the machine's cores), against the peer a lab has
# without it: the same robots calibrated one after another (n × the single run's wall time).
# Markdown on stdout.
# FLEET_SIZES overrides the sizes (e.g. "1 2").
set -uo pipefail
cd "$(dirname "$0")/../.."
sizes=${FLEET_SIZES:-"1 2 4 8"}
root=$(mktemp -d /tmp/autocal_fleet_bench.XXXX)
echo "bench/fleet: sim_fleet.launch n = $sizes (several minutes)" >&2
echo "### A fleet in one simulator"
echo
echo "\`rosrun autocal sim_fleet n:=N real_time_factor:=0\`: N default robots (camera and wheel stages,"
echo "each with its run report) on one simulator and clock, at \`sim_fleet.launch\`'s lockstep of 0.02 s,"
echo "a fleet's frames due at once rendered one robot per thread, on this machine's $(nproc) cores. \"Sim time\""
echo "is when the last robot's report came; the real-time factor is sim time / wall time. The peer is"
echo "the robots calibrated one after another: N × the 1-robot wall time. Wall time includes each"
echo "launch's start (about 5 s)."
echo
echo "| robots | succeeded | wall [s] | wall per robot [s] | sim time [s] | real-time factor | one after another [s] | fleet / one after another |"
echo "|---|---|---|---|---|---|---|---|"
single=""
failures=""
keep=0
for n in $sizes; do
  log="$root/fleet_$n.log"
  start=$(date +%s.%N)
  rosrun autocal sim_fleet n:="$n" real_time_factor:=0 calibration_root:="$root/n$n" > "$log" 2>&1
  end=$(date +%s.%N)
  wall=$(awk "BEGIN{print $end - $start}")
  ok=$(grep -c ": succeeded; report in" "$log")
  # The sim time of fleet_report_node's last line: "[ INFO] [wall, sim]: fleet_report_node: N robots in"
  sim=$(grep "fleet_report_node: .* robots in" "$log" | tail -1 | sed -E 's/.*\[[0-9.]+, ([0-9.]+)\].*/\1/')
  [ -z "$single" ] && [ "$n" = 1 ] && single=$wall
  rtf=$(awk "BEGIN{print ${sim:-0} / $wall}")
  peer="—"; ratio="—"
  if [ -n "$single" ]; then
    peer=$(awk "BEGIN{printf \"%.0f\", $n * $single}")
    ratio=$(awk "BEGIN{printf \"%.2f\", $wall / ($n * $single)}")
  fi
  printf "| %d | %d of %d | %.0f | %.0f | %.0f | %.2f | %s | %s |\n" "$n" "$ok" "$n" "$wall" \
    "$(awk "BEGIN{print $wall / $n}")" "${sim:-0}" "$rtf" "$peer" "$ratio"
  echo "bench/fleet: n=$n: $ok of $n succeeded, wall $wall s, sim ${sim:-?} s" >&2
  if [ "$ok" != "$n" ]; then
    failures="$failures$(grep "sim_fleet: robot.*FAILED" "$log" | sed "s/^/n=$n: /")"$'\n'
    keep=1
  fi
done
echo
echo "Reproduce: \`FLEET_SIZES=\"1 2 4 8\" bash scripts/bench/fleet.sh\`."
if [ -n "$failures" ]; then
  echo
  echo "Failed robots (logs kept in $root):"
  echo
  echo '```'
  printf "%s" "$failures"
  echo '```'
fi
[ "$keep" = 1 ] || rm -rf "$root"
