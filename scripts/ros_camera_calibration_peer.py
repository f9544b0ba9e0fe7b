#!/usr/bin/python3
"""The peer a user would run instead of autocal: ROS camera_calibration's MonoCalibrator (Debian
python3-camera-calibration), driven on the same photos as autocal's calibrate_camera.

Prints one JSON object: time from images to intrinsics, fx/fy/cx/cy, the training RMS, and the
leave-one-out held-out reprojection error (calibrate on all but one photo with MonoCalibrator,
fit the held-out photo's pose with those intrinsics using MonoCalibrator's own corners, RMS,
averaged over folds) with the spread of fx across folds.

Flags: cameracalibrator.py's default --k-coefficients 2, i.e. CALIB_FIX_K3 (what a user gets).
Run with Debian's /usr/bin/python3 (a pyenv python lacks the ROS modules).
"""
import argparse
import glob
import json
import sys
import time

import cv2
import numpy
from camera_calibration.calibrator import ChessboardInfo, MonoCalibrator


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--images', required=True, help="glob, e.g. 'DIR/left[0-9]*.jpg'")
    ap.add_argument('--board', default='9x6', help='inner corners COLSxROWS')
    ap.add_argument('--square', type=float, default=0.025, help='square size [m]')
    ap.add_argument('--flags', type=int, default=cv2.CALIB_FIX_K3, help='cv2.calibrateCamera flags')
    ap.add_argument('--no-holdout', action='store_true', help='stop after the intrinsics (for timing)')
    args = ap.parse_args()
    cols, rows = (int(x) for x in args.board.lower().split('x'))
    files = sorted(glob.glob(args.images))
    if not files:
        sys.exit("ros_camera_calibration_peer: no file matches %s" % args.images)
    board = ChessboardInfo(n_cols=cols, n_rows=rows, dim=args.square)

    def calibrator():
        return MonoCalibrator([board], flags=args.flags)

    t0 = time.perf_counter()
    images = [cv2.imread(f, cv2.IMREAD_GRAYSCALE) for f in files]
    cal = calibrator()
    good = cal.collect_corners(images)
    cal.cal_fromcorners(good)
    seconds = time.perf_counter() - t0

    k = cal.intrinsics
    if args.no_holdout:
        print(json.dumps({'tool': 'ros_camera_calibration', 'seconds': seconds, 'fx': float(k[0, 0])}))
        return
    (ipts, ids, boards) = zip(*good)
    opts = cal.mk_object_points(boards)

    def held_out_rms(k, d, obj, img):
        ok, rvec, tvec = cv2.solvePnP(obj, img, k, d)
        proj, _ = cv2.projectPoints(obj, rvec, tvec, k, d)
        return float(numpy.sqrt(numpy.mean(numpy.sum((proj.reshape(-1, 2) - img.reshape(-1, 2)) ** 2, axis=1))))

    fold_rms, fold_fx = [], []
    for i in range(len(good)):
        c = calibrator()
        c.size = cal.size
        c.cal_fromcorners([g for j, g in enumerate(good) if j != i])
        fold_rms.append(held_out_rms(c.intrinsics, c.distortion, opts[i], ipts[i]))
        fold_fx.append(float(c.intrinsics[0, 0]))
    print(json.dumps({
        'tool': 'ros_camera_calibration', 'images': len(files), 'views': len(good),
        'seconds': seconds, 'fx': float(k[0, 0]), 'fy': float(k[1, 1]), 'cx': float(k[0, 2]),
        'cy': float(k[1, 2]), 'distortion': [float(x) for x in cal.distortion.flat],
        'holdout_rms_px': float(numpy.mean(fold_rms)), 'fx_spread_px': max(fold_fx) - min(fold_fx),
        'fold_fx': fold_fx}))


if __name__ == '__main__':
    main()
