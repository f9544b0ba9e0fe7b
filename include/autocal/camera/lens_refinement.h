// The corners refined again once the lens is known. cv::cornerSubPix fits the saddle point of
// straight edges; a wide lens bends a board's edges within the refinement window, and the
// refined corner moves radially by a few hundredths of a pixel (outward near the middle of the
// image, inward towards its edge). That bias is smooth over the image, so the fit takes it for
// distortion, and where no board was seen (the lower half, the corners) the written model is
// then off by several times its predicted uncertainty. Resampled through the fitted lens into the
// image a pinhole camera looking along the corner's ray would see, the edges are straight again
// and the refinement unbiased; the corner is mapped back through the same lens. This is the
// undistort-and-redetect step of iterative control-point refinement (Datta, Kim, Kanade, ICCV
// Workshops 2009), done per corner on the pixels kept with each view.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "autocal/camera/chessboard.h"
#include "autocal/camera_intrinsics.h"

namespace autocal {
namespace camera {

/// The grey pixels around one board, kept with its view for refining it again.
struct BoardPatch {
  cv::Mat gray;      ///< CV_8U; empty when none was kept
  cv::Point origin;  ///< the patch's top-left pixel in the image
};

/// The bounding box of `corners` grown by `margin_px` (clipped to the image), copied.
BoardPatch boardPatch(const cv::Mat& gray, const std::vector<cv::Point2f>& corners, int margin_px);

/// Corners refined again, each in the image a pinhole camera looking along the corner's ray (focal
/// length: the lens's fx) would see around it, resampled from the patch through `lens`
/// (bicubic), with refineCorners's window. A corner whose window leaves the patch, or that would
/// move more than 1 px, keeps its position. Returns `corners` unchanged when the patch is empty.
std::vector<cv::Point2f> refineThroughLens(const BoardPatch& patch, const BoardSpec& spec,
                                           const std::vector<cv::Point2f>& corners,
                                           const CameraIntrinsics& lens,
                                           const ChessboardDetectorOptions& options);

}  // namespace camera
}  // namespace autocal
