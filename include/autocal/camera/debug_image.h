// The camera stage's debug image (what rqt_image_view shows on ~debug/image/compressed): the last
// processed frame with every board found (green: kept for coverage, yellow: sharp, used by the
// fit, red: refused), the coverage of each view parameter as bars, and one line of state.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "autocal/camera/view_selection.h"

namespace autocal {
namespace camera {

/// A BGR copy of `frame` (grey or BGR) with the boards of `result`, the coverage bars and `text`.
cv::Mat drawSweepDebugImage(const cv::Mat& frame, const FrameResult& result,
                            const Coverage& coverage, const std::string& text);

}  // namespace camera
}  // namespace autocal
