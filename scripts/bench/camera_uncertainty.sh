#!/usr/bin/env bash
# Projection uncertainty benchmark, called by scripts/bench.sh: prints one Markdown section on
# stdout, progress on stderr. On OpenCV's real photos (opencv-doc left*.jpg, 9x6 inner corners,
# 25 mm): autocal's calibrate_camera, then mrcal (python3-mrcal, scripts/mrcal_uncertainty_peer.py)
# on the same corners with the same lens model; their projection uncertainty over the same grid.
set -euo pipefail
cd "$(dirname "$0")/../.."
photos="/usr/share/doc/opencv-doc/examples/data/left[0-9]*.jpg"
bin=build/devel/lib/autocal
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "camera uncertainty bench: autocal calibrate_camera, mrcal on its corners" >&2
"$bin/calibrate_camera" --images "$photos" --board 9x6 --square 0.025 --min-novelty 0 \
  --out "$tmp/left.yaml" > "$tmp/autocal.log"
peer=$(/usr/bin/python3 scripts/mrcal_uncertainty_peer.py "$tmp/left_views/views.yaml")
echo "### Projection uncertainty: autocal vs mrcal"
echo
if echo "$peer" | grep -q '"error"'; then
  echo "Not measured: $(echo "$peer" | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["error"])')"
  echo "(\`apt-get install python3-mrcal\`)."
  exit 0
fi
/usr/bin/python3 - "$tmp/left_views/views.yaml" "$peer" <<'PY'
import json, sys, yaml
audit = yaml.safe_load(open(sys.argv[1]))
peer = json.loads(sys.argv[2])
u = audit["projection_uncertainty"]
cols, rows = u["grid"]
sigma = u["sigma_px"]
centre = sigma[(rows // 2) * cols + cols // 2]
k = yaml.safe_load(open(sys.argv[1].replace("_views/views.yaml", ".yaml")))["camera_matrix"]["data"]
print("OpenCV's `left*.jpg` (%d views, the same corners, k1 k2 p1 p2 with k3 held at 0), the "
      "worst-direction standard deviation of projection over a %dx%d grid of the image "
      "(`scripts/bench/camera_uncertainty.sh`). mrcal compensates the motion of the reference "
      "frame between calibrations; autocal predicts the projection difference of a ray fixed in the "
      "camera frame, as the simulator measures it, so its figures are larger where the principal "
      "point's uncertainty dominates (the middle)." % (peer["views"], cols, rows))
print()
print("| | fx | cx | centre [px] | RMS over the image [px] | worst [px] | lower half worst [px] |")
print("|---|---|---|---|---|---|---|")
print("| autocal | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f |" % (
    k[0], k[2], centre, u["rms_px"], u["worst_px"], u["lower_half_worst_px"]))
print("| mrcal 2.2 | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f |" % (
    peer["fx"], peer["cx"], peer["uncertainty_centre_px"], peer["uncertainty_rms_px"],
    peer["uncertainty_worst_px"], peer["uncertainty_lower_half_worst_px"]))
h = audit.get("halves_cross_validation")
if h:
    print()
    print("autocal's cross-validation by halves (%d views each): difference RMS %.3f px, %.2f "
          "times what the halves' uncertainties allow." % (h["views_each"], h["rms_px"], h["ratio"]))
PY
