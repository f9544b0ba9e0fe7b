#!/usr/bin/env bash
# make bench, simulator section: render ms/frame and real-time factors (stop-and-shoot sweep, straight
# drives, continuous driving; today's path beside now's) with and without the camera,
# pinned to one core. Prints Markdown on stdout.
set -euo pipefail
cd "$(dirname "$0")/../.."
echo "bench/sim: rendering and stepping, today's path beside now's (about five minutes)" >&2
taskset -c 0 build/bench/sim_bench sim/config/robot.yaml sim/config/world.yaml "${SIM_BENCH_SECONDS:-60}"
cat <<'NOTE'
Issue 13's targets on one core, from this run (2026-11-24, while a helper's build and rostests kept
the machine's load at 2-5 on its 2 cores; CPU time of one pinned thread, today's and now's paths of
each figure run one after the other): continuous driving 7.6x real time (target 3: met); a
stop-and-shoot sweep 6.3x and straight drives 7.5x (target 10: not met); a still frame rendered
anew 5.65 ms (target 3: not met); a still frame of a robot standing still 0.32 ms.

What changed in this session, measured side by side (the "now / today" column):
- A blurred frame of 4 or more poses renders n/2 + 1 of them (the first and the last, none more
  than two apart) at half resolution, 2x2 pixels to a pixel, and scales their average up with one
  bilinear cv::resize (`blur_half_res_poses`): an 8-pose frame 23.5 -> 5.9 ms (0.25x). The motion
  smears such a frame by at least 4 px along the motion; across it the frame is about one pixel
  softer than with full-resolution poses. The renderer test (`HalfResolutionBlurLandsWhere...`)
  finds the board corners of a half-resolution frame within 0.2 px on average of the
  full-resolution poses' (a scaling off by half a pixel would show as 0.25-0.5 px), each within
  1.5 px (neither is anti-aliased). The wheel stage on the simulator's core
  (test_wheel_run_in_sim, 6 robots and the replay) gives the same trims, deadbands and drive counts
  as before, to the last digit.
- An edge pixel whose four corners lie on one plane (a board's squares, the floor's tags and lines,
  a wall's posters) colours its 9 samples at their points on that plane, interpolated between its
  corners' points, instead of tracing 9 rays through the scene (`edge_samples_on_plane`): a still
  frame 6.58 -> 5.65 ms (0.86x). The renderer test's board corners: worst view RMS 0.0999 px
  (0.0990 px before; bound 0.15), the floor tag 0.44 mm and 0.17 deg (the same).
- Measured and not adopted: the gearbox's static friction catching a coasting wheel below the
  deadband's speed (the wheel stops about 0.09 s after a pulse instead of creeping for 0.6 s):
  the sweep's frames rendered anew fell from 931 to 152 per minute and its real-time factor rose
  2.1x (3.5 -> 7.4, before the two changes above), but the camera stage's minimum-duty probe then
  found 0.12 for a deadband of 0.08 (it counts the ticks of the creep; test bound deadband + 0.03)
  and the wheel stage needed 13 drives instead of 9 (bound 10): the stages' tests are tuned to the
  creeping wheels, and changing the physics under them was left for a session with time to retune.

Why the remaining targets stay out of reach: the sweep's time is now mostly still frames rendered
anew while the robot creeps after each pulse (931 a minute, 76 of 160 CPU ms per simulated s),
then blurred frames (54) and JPEG encoding (27, about 0.85 ms a frame; every frame has fresh noise,
so every frame is encoded). A still frame traces about 47 000 pixel-corner rays and samples 8 800
edge pixels; profiled (perf), its time is spread over the block and pixel shading (about 40 %), the
boards', walls' and floor's colour look-ups (about 20 %) and the kernel's page faults and
reschedules on this shared virtual machine. Reaching 3 ms needs the per-plane renderer (floor and
walls through homographies of prebuilt textures, the lens by one cv::remap of a precomputed map,
the 0.15 px corner bound shown again), or the creep gone from the physics (above).
NOTE
echo
echo "Reproduce: \`make build && taskset -c 0 build/bench/sim_bench sim/config/robot.yaml sim/config/world.yaml 60\`."
