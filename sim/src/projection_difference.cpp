#include "autocal/sim/projection_difference.h"

#include <algorithm>
#include <cmath>

#include "autocal/errors.h"
#include "autocal/sim/camera_model.h"

namespace autocal {
namespace sim {

ProjectionDifference projectionDifference(const CameraIntrinsics& truth,
                                          const CameraIntrinsics& calibrated, int step_px,
                                          double centre_radius_px, double cap_px) {
  checkConfig(step_px >= 1, "step_px", "must be >= 1");
  checkConfig(truth.width > 0 && truth.height > 0, "truth", "needs an image size");
  const CameraModel lens(truth), model(calibrated);
  ProjectionDifference out;
  double sum = 0, centre = 0, upper = 0, lower = 0;
  int n_centre = 0, n_upper = 0, n_lower = 0;
  const double mid_u = 0.5 * truth.width, mid_v = 0.5 * truth.height;
  for (double v = 0.5 * step_px; v < truth.height; v += step_px) {
    for (double u = 0.5 * step_px; u < truth.width; u += step_px) {
      Eigen::Vector3d ray;
      Eigen::Vector2d pixel;
      double d = cap_px;
      if (!lens.ray(u, v, &ray) || !model.project(ray, &pixel)) {
        ++out.unmapped;
      } else {
        d = std::min(cap_px, std::hypot(pixel.x() - u, pixel.y() - v));
      }
      ++out.pixels;
      sum += d * d;
      if (d > out.worst_px) {
        out.worst_px = d;
        out.worst_u_px = u;
        out.worst_v_px = v;
      }
      if (std::hypot(u - mid_u, v - mid_v) <= centre_radius_px) centre += d * d, ++n_centre;
      if (v < mid_v) {
        upper += d * d, ++n_upper;
      } else {
        lower += d * d, ++n_lower;
      }
    }
  }
  auto rms = [](double s, int n) { return n > 0 ? std::sqrt(s / n) : 0.0; };
  out.rms_px = rms(sum, out.pixels);
  out.centre_rms_px = rms(centre, n_centre);
  out.upper_rms_px = rms(upper, n_upper);
  out.lower_rms_px = rms(lower, n_lower);
  return out;
}

}  // namespace sim
}  // namespace autocal
