#include "autocal/report/camera_view.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <string>

namespace autocal {
namespace report {

void drawTagDetections(cv::Mat& image, const std::vector<markers::TagDetection>& detections) {
  // RViz shows the image scaled down in a small panel: lines of a full-size image's 1/200.
  const int thickness = std::max(2, cvRound(image.cols / 200.0));
  for (const markers::TagDetection& d : detections) {
    for (int i = 0; i < 4; ++i) {
      const cv::Point a(cvRound(d.corners_px[i].x), cvRound(d.corners_px[i].y));
      const cv::Point b(cvRound(d.corners_px[(i + 1) % 4].x), cvRound(d.corners_px[(i + 1) % 4].y));
      cv::line(image, a, b, i == 0 ? cv::Scalar(0, 0, 255) : cv::Scalar(0, 220, 0), thickness,
               cv::LINE_AA);
    }
    cv::putText(image, std::to_string(d.id),
                cv::Point(cvRound(d.center_px.x) - 8, cvRound(d.center_px.y) + 6),
                cv::FONT_HERSHEY_SIMPLEX, 0.3 * thickness, cv::Scalar(0, 128, 255), thickness,
                cv::LINE_AA);
  }
}

}  // namespace report
}  // namespace autocal
