// The lens distortion models autocal knows, by their ROS camera_info names; shared by the camera
// calibration and the simulator's true camera.
#pragma once

#include <cstddef>
#include <string>

namespace autocal {

enum class DistortionModel { kPlumbBob, kRationalPolynomial, kEquidistant };

/// The ROS camera_info name: "plumb_bob", "rational_polynomial", "equidistant".
std::string distortionModelName(DistortionModel model);
/// Parses a ROS name (also "rational" and "fisheye"); throws ConfigError naming the choices.
DistortionModel parseDistortionModel(const std::string& name);
/// Number of coefficients the model takes in ROS order (5, 8, 4).
size_t distortionCoefficientCount(DistortionModel model);

}  // namespace autocal
