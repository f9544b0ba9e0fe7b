#!/usr/bin/env bash
# make bench, simulator section: render ms/frame and real-time factors (stop-and-shoot sweep, straight
# drives, continuous driving; the renderer's and the physics' shortcuts on and off, side by side)
# with and without the camera, pinned to one core. Prints Markdown on stdout.
set -euo pipefail
cd "$(dirname "$0")/../.."
echo "bench/sim: rendering and stepping, shortcuts on and off (about five minutes)" >&2
taskset -c 0 build/bench/sim_bench sim/config/robot_ideal.yaml sim/config/world.yaml "${SIM_BENCH_SECONDS:-60}"
cat <<'NOTE'

The frame counts do not depend on the machine. A still frame traces about 47 000 pixel-corner rays
and samples 8 800 edge pixels; profiled (perf), its time is spread over the block and pixel shading
(about 40 %), the boards', walls' and floor's colour look-ups (about 20 %) and the camera model. A
blurred frame of 4 or more poses renders n/2 + 1 of them at half resolution: smeared by at least
4 px along the motion, softened by about one more pixel across it, its board corners within 0.2 px
on average of the full-resolution poses'.

Measured and not adopted: static (Coulomb) friction catching a coasting wheel, which stops it within
about 0.09 s of a pulse (the robot YAML's optional breakaway duty acts only on a wheel at rest),
raised the sweep's real-time factor 2.1x but changed how the wheels stop: the minimum-duty
probe found 0.12-0.13 for a deadband of 0.08, the wheel stage needed 11-14 drives instead of 9 and
missed its drift bounds for 2 of 6 robots, and a hard stop from 0.5 m/s slipped 2.8 ticks past the
wheels' traction.
NOTE
echo
echo "Reproduce: \`make build && taskset -c 0 build/bench/sim_bench sim/config/robot_ideal.yaml sim/config/world.yaml 60\`"
echo "(or \`bash scripts/bench/sim.sh\`)."
