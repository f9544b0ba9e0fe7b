// Where the camera stage looks for more views when the views of its sweep fail the quality gate:
// where the projection is least sure, as mrcal advises (its documentation, "How to get good
// calibration data": more observations where the uncertainty is high). The targets are the grid
// cells of the largest projection uncertainty; for each, the heading at which a board corner the
// sweep saw comes to it. The robot only turns, so a corner moves across the image at about its
// own elevation: the corner whose ray's elevation is nearest the cell's is brought to the cell's
// azimuth. ROS-free.
#pragma once

#include <map>
#include <opencv2/core.hpp>
#include <vector>

#include "autocal/camera/projection_uncertainty.h"
#include "autocal/camera/view_selection.h"
#include "autocal/camera_intrinsics.h"

namespace autocal {
namespace camera {

struct ViewTarget {
  cv::Point2d pixel;  ///< the cell's centre [px]
  /// Its uncertainty [px] (infinite: the model maps no ray there); without a valid uncertainty,
  /// the distance from the cell's centre to the nearest corner seen [px].
  double need = 0;
  /// The heading that brings the chosen corner to the cell [rad, on the heading of the views'
  /// `heading_by_frame`, + = counter-clockwise].
  double heading_rad = 0;
  cv::Point2d corner_px;  ///< the chosen corner, where it was seen [px]
  int frame_index = -1;   ///< of the view it was seen in
  /// How far the corner's elevation is from the cell's [rad]: turning cannot close it.
  double elevation_miss_rad = 0;
};

/// The target of each of `regions` vertical strips of the image (left to right): its cell of the
/// largest `uncertainty` (grid of `fit`'s image), or, when the uncertainty is not valid, the
/// cell farthest from every corner seen. `views` were each taken at heading_by_frame[frame_index]
/// (views without one are skipped); among the corners of equal elevation, the one the least turn
/// from `current_heading_rad` brings there is chosen. Angles are taken about the camera's own
/// vertical axis (the mount's pitch is not known to the camera stage): a round of views corrects
/// what that leaves off. Empty when no view has a heading or the grid is empty.
std::vector<ViewTarget> viewTargets(const ProjectionUncertainty& uncertainty,
                                    const CameraIntrinsics& fit,
                                    const std::vector<CalibrationView>& views,
                                    const std::map<int, double>& heading_by_frame,
                                    double current_heading_rad, int regions = 2);

}  // namespace camera
}  // namespace autocal
