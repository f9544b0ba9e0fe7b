#include "autocal/io/camera_info_file.h"

#include <cmath>

#include "autocal/errors.h"
#include "autocal/io/yaml_reader.h"

namespace autocal {

namespace {

/// A camera_info matrix: {rows, cols, data} with rows × cols numbers.
std::vector<double> matrixData(YamlMap& parent, const std::string& key, int rows, int cols) {
  YamlMap m = parent.map(key);
  const int r = m.required<int>("rows");
  const int c = m.required<int>("cols");
  const std::vector<double> data = m.required<std::vector<double>>("data");
  if ((rows > 0 && r != rows) || (cols > 0 && c != cols)) {
    const std::string want =
        std::to_string(rows) + "x" + (cols > 0 ? std::to_string(cols) : std::string("N"));
    m.fail("", "expected " + want + ", got " + std::to_string(r) + "x" + std::to_string(c));
  }
  if (r < 0 || c < 0 || static_cast<size_t>(r) * static_cast<size_t>(c) != data.size()) {
    m.fail("data", "has " + std::to_string(data.size()) + " numbers, rows x cols is " +
                       std::to_string(r) + "x" + std::to_string(c));
  }
  for (double v : data) {
    if (!std::isfinite(v)) m.fail("data", "must be finite numbers");
  }
  return data;
}

CameraIntrinsics fromMap(YamlMap& y) {
  CameraIntrinsics in;
  in.width = y.required<int>("image_width");
  in.height = y.required<int>("image_height");
  if (in.width <= 0) y.fail("image_width", "must be > 0 [px]");
  if (in.height <= 0) y.fail("image_height", "must be > 0 [px]");
  const std::vector<double> k = matrixData(y, "camera_matrix", 3, 3);
  in.fx = k[0];
  in.cx = k[2];
  in.fy = k[4];
  in.cy = k[5];
  if (!(in.fx > 0 && in.fy > 0)) y.fail("camera_matrix", "fx and fy must be > 0 [px]");
  try {
    in.distortion_model =
        parseDistortionModel(y.optional<std::string>("distortion_model", "plumb_bob"));
  } catch (const ConfigError& e) {
    y.fail("distortion_model", e.what());
  }
  in.distortion_coefficients = matrixData(y, "distortion_coefficients", 1, -1);
  const size_t n = distortionCoefficientCount(in.distortion_model);
  // camera_calibration writes 5 coefficients for plumb_bob; fewer (or none) mean zeros.
  if (in.distortion_coefficients.size() > n) {
    y.fail("distortion_coefficients", distortionModelName(in.distortion_model) + " takes " +
                                          std::to_string(n) + " coefficients, got " +
                                          std::to_string(in.distortion_coefficients.size()));
  }
  in.distortion_coefficients.resize(n, 0.0);
  return in;
}

}  // namespace

CameraInfoFile loadCameraInfoFile(const std::string& path) {
  YamlMap y = YamlMap::loadFile(path);
  CameraInfoFile f;
  f.intrinsics = fromMap(y);
  if (y.has("rectification_matrix")) {
    const std::vector<double> r = matrixData(y, "rectification_matrix", 3, 3);
    for (int i = 0; i < 9; ++i) f.rectification(i / 3, i % 3) = r[static_cast<size_t>(i)];
  }
  const std::vector<double> p = matrixData(y, "projection_matrix", 3, 4);
  for (int i = 0; i < 12; ++i) f.projection(i / 4, i % 4) = p[static_cast<size_t>(i)];
  if (!(f.projection(0, 0) > 0 && f.projection(1, 1) > 0))
    y.fail("projection_matrix", "fx and fy must be > 0 [px]");
  return f;
}

CameraIntrinsics loadCameraInfoYaml(const std::string& path) {
  YamlMap y = YamlMap::loadFile(path);
  return fromMap(y);
}

CameraIntrinsics parseCameraInfoYaml(const std::string& text, const std::string& file) {
  YamlMap y = YamlMap::fromString(text, file);
  return fromMap(y);
}

}  // namespace autocal
