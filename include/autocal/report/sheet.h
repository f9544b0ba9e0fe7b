// The report sheet, a PNG for a person: the views used and their reprojection errors, the image
// coverage by board corners, the wheel stage's believed path and k per iteration, the odometry
// figures, pass/fail. ROS-free.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "autocal/report/gates.h"
#include "autocal/report/run_record.h"

namespace autocal {
namespace report {

/// The sheet (BGR, 1600 × 1040). `ground_view`: the wheel stage's floor grid over a rectified
/// frame (camera_extrinsic/<veh>_ground.png), or empty.
cv::Mat drawReportSheet(const RunRecord& record, const ViewsAudit& audit,
                        const ReportOptions& options, const std::string& time_utc,
                        const cv::Mat& ground_view = cv::Mat());

}  // namespace report
}  // namespace autocal
