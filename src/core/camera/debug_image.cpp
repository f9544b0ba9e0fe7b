#include "autocal/camera/debug_image.h"

#include <opencv2/imgproc.hpp>

namespace autocal {
namespace camera {

cv::Mat drawSweepDebugImage(const cv::Mat& frame, const FrameResult& result,
                            const Coverage& coverage, const std::string& text) {
  cv::Mat out;
  if (frame.channels() == 1) {
    cv::cvtColor(frame, out, cv::COLOR_GRAY2BGR);
  } else {
    out = frame.clone();
  }
  for (const ViewDecision& d : result.decisions) {
    const cv::Scalar colour = d.kept    ? cv::Scalar(0, 200, 0)
                              : d.sharp ? cv::Scalar(0, 200, 255)
                                        : cv::Scalar(0, 0, 255);
    for (const cv::Point2f& p : d.corners) cv::circle(out, p, 3, colour, 1, cv::LINE_AA);
  }
  // Coverage: one bar per view parameter, full when its spread reaches the goal.
  static const char* kNames[6] = {"X", "Y", "size", "skew", "dist", "tilt"};
  const int bar_w = 60, bar_h = 10, x0 = 8;
  int y = out.rows - 6 * (bar_h + 4) - 24;
  for (int i = 0; i < 6; ++i, y += bar_h + 4) {
    const double p = coverage.progress[static_cast<size_t>(i)];
    cv::rectangle(out, cv::Rect(x0 + 40, y, bar_w, bar_h), cv::Scalar(80, 80, 80), cv::FILLED);
    cv::rectangle(out, cv::Rect(x0 + 40, y, static_cast<int>(bar_w * p), bar_h),
                  p >= 1 ? cv::Scalar(0, 200, 0) : cv::Scalar(0, 200, 255), cv::FILLED);
    cv::putText(out, kNames[i], cv::Point(x0, y + bar_h), cv::FONT_HERSHEY_SIMPLEX, 0.35,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
  cv::putText(out, std::to_string(coverage.views) + " views", cv::Point(x0, y + 10),
              cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  cv::rectangle(out, cv::Rect(0, 0, out.cols, 18), cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(out, text, cv::Point(4, 13), cv::FONT_HERSHEY_SIMPLEX, 0.38,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return out;
}

}  // namespace camera
}  // namespace autocal
