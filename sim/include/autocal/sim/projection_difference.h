// How far a calibrated camera model is from the simulator's true lens over the whole image (a
// validation of a calibration; no calibration reads it): for a grid of pixels, the true lens's
// ray through the pixel is projected with the calibrated model, and the distance to the pixel is
// the model's error there. Unlike the reprojection error of the views, it covers the parts of the
// image no view showed. No ROS.
#pragma once

#include "autocal/camera_intrinsics.h"

namespace autocal {
namespace sim {

struct ProjectionDifference {
  int pixels = 0;     ///< grid pixels compared
  int unmapped = 0;   ///< grid pixels the calibrated model cannot project (behind it, or no ray)
  double rms_px = 0;  ///< over every compared pixel
  double worst_px = 0;
  double worst_u_px = 0, worst_v_px = 0;  ///< the grid pixel where worst_px is
  double centre_rms_px = 0;  ///< within centre_radius_px of the image centre
  double upper_rms_px = 0;   ///< the upper half of the image (rows above the middle)
  double lower_rms_px = 0;   ///< the lower half: where a lane follower looks at the floor
};

/// The difference on a grid of `step_px` over `truth`'s image (its width and height), pixel
/// centres included from (step/2, step/2). Differences over `cap_px` count as `cap_px` (a model
/// that diverges in a corner would otherwise dominate every figure). Throws ConfigError for
/// step_px < 1 or a truth without an image size.
ProjectionDifference projectionDifference(const CameraIntrinsics& truth,
                                          const CameraIntrinsics& calibrated, int step_px = 8,
                                          double centre_radius_px = 100, double cap_px = 1000);

}  // namespace sim
}  // namespace autocal
