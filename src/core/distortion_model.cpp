#include "autocal/distortion_model.h"

#include "autocal/errors.h"

namespace autocal {

std::string distortionModelName(DistortionModel model) {
  switch (model) {
    case DistortionModel::kPlumbBob:
      return "plumb_bob";
    case DistortionModel::kRationalPolynomial:
      return "rational_polynomial";
    case DistortionModel::kEquidistant:
      return "equidistant";
  }
  return "unknown";
}

DistortionModel parseDistortionModel(const std::string& name) {
  if (name == "plumb_bob") return DistortionModel::kPlumbBob;
  if (name == "rational_polynomial" || name == "rational")
    return DistortionModel::kRationalPolynomial;
  if (name == "equidistant" || name == "fisheye") return DistortionModel::kEquidistant;
  throw ConfigError("unknown distortion model '" + name +
                    "' (expected plumb_bob, rational_polynomial or equidistant)");
}

size_t distortionCoefficientCount(DistortionModel model) {
  switch (model) {
    case DistortionModel::kPlumbBob:
      return 5;
    case DistortionModel::kRationalPolynomial:
      return 8;
    case DistortionModel::kEquidistant:
      return 4;
  }
  return 0;
}

}  // namespace autocal
