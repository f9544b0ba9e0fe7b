#!/usr/bin/python3
"""mrcal's projection uncertainty for the corners of an autocal calibration, for a side-by-side
benchmark (scripts/bench/camera.sh).

    /usr/bin/python3 scripts/mrcal_uncertainty_peer.py VIEWS_YAML

Reads autocal's audit (<camera>_views/views.yaml: the board, the image size, the fitted model and
every view's corners) and the intrinsics beside it (<camera>.yaml), solves the same problem with
mrcal (Debian's python3-mrcal 2.2: the same corners, the same lens model, k3 held at 0 as autocal
held it, no regularisation, no outlier rejection), and prints one JSON line: mrcal's fx, fy, cx,
cy, its RMS, and the worst-direction standard deviation of projection at infinity
(mrcal.projection_uncertainty) over autocal's grid of cell centres: RMS, worst and the worst of
the lower half. mrcal compensates the motion of the reference frame between calibrations; autocal
does not (it predicts the projection difference of a ray fixed in the camera frame), so autocal's
figures are expected larger, most where the principal point dominates.
"""
import json
import os
import sys

import numpy
import yaml

try:
    import cv2
    import mrcal
except ImportError as e:  # the bench skips the section
    print(json.dumps({"error": "python3-mrcal is not installed (%s)" % e}))
    sys.exit(0)


def main():
    views_yaml = sys.argv[1]
    audit = yaml.safe_load(open(views_yaml))
    camera_yaml = os.path.dirname(os.path.abspath(views_yaml))
    camera_yaml = camera_yaml[: -len("_views")] + ".yaml"
    cam = yaml.safe_load(open(camera_yaml))
    cols, rows = (int(x) for x in audit["board"]["inner_corners"].split("x"))
    spacing = float(audit["board"]["square_size_m"])
    width, height = int(audit["image"]["width"]), int(audit["image"]["height"])
    k = numpy.array(cam["camera_matrix"]["data"], float).reshape(3, 3)
    d = numpy.array(cam["distortion_coefficients"]["data"], float)
    if audit["distortion_model"] != "plumb_bob" or abs(d[4]) > 0:
        print(json.dumps({"error": "only plumb_bob with k3 held at 0 is compared"}))
        return
    board = numpy.zeros((rows, cols, 3))
    board[..., 0] = numpy.arange(cols)[None, :] * spacing
    board[..., 1] = numpy.arange(rows)[:, None] * spacing
    obs, frames = [], []
    for v in audit["views"]:
        c = numpy.array(v["corners"], float).reshape(rows, cols, 2)
        ok, rvec, tvec = cv2.solvePnP(board.reshape(-1, 3), c.reshape(-1, 2), k, d[:5])
        frames.append(numpy.hstack((rvec.ravel(), tvec.ravel())))
        obs.append(numpy.concatenate((c, numpy.ones((rows, cols, 1))), axis=2))
    n = len(obs)
    inputs = dict(
        intrinsics=numpy.array([[k[0, 0], k[1, 1], k[0, 2], k[1, 2], d[0], d[1], d[2], d[3]]]),
        extrinsics_rt_fromref=numpy.zeros((0, 6)),
        frames_rt_toref=numpy.array(frames),
        points=None,
        observations_board=numpy.array(obs),
        indices_frame_camintrinsics_camextrinsics=numpy.array(
            [[i, 0, -1] for i in range(n)], dtype=numpy.int32),
        observations_point=None,
        indices_point_camintrinsics_camextrinsics=None,
        lensmodel="LENSMODEL_OPENCV4",
        imagersizes=numpy.array([[width, height]], dtype=numpy.int32),
        calibration_object_spacing=spacing,
        do_optimize_intrinsics_core=True,
        do_optimize_intrinsics_distortions=True,
        do_optimize_extrinsics=True,
        do_optimize_frames=True,
        do_optimize_calobject_warp=False,
        do_apply_outlier_rejection=False,
        do_apply_regularization=False,
        verbose=False,
    )
    stats = mrcal.optimize(**inputs)
    model = mrcal.cameramodel(optimization_inputs=inputs, icam_intrinsics=0)
    u = audit["projection_uncertainty"]
    gc, gr = u["grid"]
    q = numpy.array([[(c + 0.5) * width / gc, (r + 0.5) * height / gr]
                     for r in range(gr) for c in range(gc)])
    v = mrcal.unproject(q, *model.intrinsics())
    sigma = mrcal.projection_uncertainty(v, model=model, atinfinity=True,
                                         what="worstdirection-stdev")
    lower = sigma.reshape(gr, gc)[gr // 2:, :]
    intr = model.intrinsics()[1]
    print(json.dumps({
        "fx": intr[0], "fy": intr[1], "cx": intr[2], "cy": intr[3],
        "rms_px": float(stats["rms_reproj_error__pixels"]),
        "views": n,
        "uncertainty_rms_px": float(numpy.sqrt(numpy.mean(sigma ** 2))),
        "uncertainty_worst_px": float(numpy.max(sigma)),
        "uncertainty_lower_half_worst_px": float(numpy.max(lower)),
        "uncertainty_centre_px": float(sigma.reshape(gr, gc)[gr // 2, gc // 2]),
    }))


if __name__ == "__main__":
    main()
