// Intrinsic calibration from kept chessboard views (Zhang's method, paper 000 §1: OpenCV's least
// squares, solved in joint_fit.h): pinhole + plumb_bob by default, rational_polynomial and fisheye
// (equidistant) as options.
// Distortion terms the views cannot constrain are held fixed (chosen by held-out error), outlier
// views and corners are dropped and the model refitted, and a quality gate decides whether a result
// may replace a calibration file.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "autocal/camera/chessboard.h"
#include "autocal/camera/projection_uncertainty.h"
#include "autocal/camera_intrinsics.h"
#include "autocal/distortion_model.h"

namespace autocal {
namespace camera {

using autocal::DistortionModel;
using autocal::distortionModelName;
using autocal::parseDistortionModel;

struct CalibrationOptions {
  DistortionModel model = DistortionModel::kPlumbBob;
  /// Lens models fitted after `model` (calibrateChoosingModel), in order of preference. Empty:
  /// `model` is pinned.
  std::vector<DistortionModel> fallback_models{DistortionModel::kRationalPolynomial,
                                               DistortionModel::kEquidistant};
  /// Of the models the gate passes, those whose all_corners_rms_px is within this fraction of the
  /// lowest explain the corners equally well [1].
  double model_rms_margin = 0.05;
  /// In all_corners_rms_px, each corner's residual counts up to this many times the fit's RMS:
  /// a corner detected wrong weighs about the same for every model. At 5, a four-term
  /// equidistant fit bending towards one such corner among 10-12 views of a plumb_bob lens beat
  /// plumb_bob by the margin in 3 of 24 draws; at 3, in none [1].
  double model_corner_cap_factor = 3.0;
  /// Of those, a model later in the order replaces an earlier one when its projection
  /// uncertainty (RMS over the image) is lower by more than this fraction, or its worst cell is
  /// lower by more than it and less than half with the RMS no higher (muchSurer): it is the one
  /// the views pin down where no board was seen [1].
  double model_uncertainty_margin = 0.2;
  /// Fewer views than this are refused.
  int min_views = 6;
  /// Views are "all alike" when the spread of every one of X, Y, size, skew and tilt is below this.
  double min_param_spread = 0.05;
  /// Hold fixed (at 0) the distortion terms the views cannot constrain. Term sets are nested,
  /// simplest first (plumb_bob: k1 k2 | + p1 p2 | + k3).
  bool select_distortion_terms = true;
  /// kSignificance: start from all terms and drop the last group while none of its terms is
  /// significant (|value| < min_term_significance · its standard deviation) and, for a group of
  /// several terms, the group as a whole is not (it lowers the RMS by no more than
  /// model_rms_margin, or the corners' chi-square by less than min_term_significance² per term);
  /// 2–3 fits, fast.
  /// kHoldout: the simplest set whose cross-validated held-out RMS is within selection_margin of
  /// the best; slower (a fit per fold and set).
  enum class Selection { kSignificance, kHoldout };
  Selection selection = Selection::kSignificance;
  double min_term_significance = 3.0;
  /// The richest term set fitted (0 the simplest); -1: every set. calibrateChoosingModel lowers it
  /// for a model whose halves' cross-validation fails with a term set the significance kept.
  int max_term_set = -1;
  double selection_margin = 0.02;
  /// Held-out folds for kHoldout (view i is held out in fold i mod folds); leave-one-out when
  /// there are no more views than this.
  int max_selection_folds = 6;
  /// A corner whose residual exceeds max(outlier_corner_factor · median view RMS,
  /// outlier_corner_min_px) is dropped; a view is dropped when more than
  /// max_outlier_corner_fraction of its corners are, or when the RMS of its other corners exceeds
  /// max(outlier_view_factor · median view RMS, outlier_view_min_px); then the model is refitted.
  /// Rounds until nothing is dropped.
  double outlier_view_factor = 3.0;
  double outlier_view_min_px = 0.5;
  double outlier_corner_factor = 4.0;
  double outlier_corner_min_px = 1.0;
  double max_outlier_corner_fraction = 0.2;
  int max_outlier_rounds = 3;
  /// A view the rest disagree with: when a model's halves' cross-validation fails (after the
  /// simpler term sets), calibrateChoosingModel drops the view with the largest RMS if it is at
  /// least halves_outlier_view_factor times the median view's, refits, and takes the fit if the
  /// gate passes it; up to max_halves_outlier_views views, one at a time. Below
  /// outlier_view_min_px such a view is not dropped as an outlier, yet one view of a wide lens
  /// (3 times the median) pulled k3 and set the halves 5.3 times their uncertainty apart.
  double halves_outlier_view_factor = 2.0;
  int max_halves_outlier_views = 2;
  /// Views kept after dropping outliers must stay at least this fraction of the input.
  double min_kept_fraction = 0.5;
  /// Camera matrix to start every fit from (e.g. camera_info's nominal model; its distortion is
  /// not used: the terms start at 0). Without one, OpenCV's closed-form start (Zhang), which on
  /// views all at one height in the image can end in a wrong minimum (the simulator's sweep:
  /// fx 703 px for a true 318, RMS 1 px).
  std::optional<cv::Matx33d> initial_camera_matrix;
  /// The lens models (calibrateChoosingModel, and the first fits the corners are refined through)
  /// are fitted on up to this many threads at once, one model each; 0: one per core. The result
  /// is the same for any number.
  int threads = 0;
  /// Predict the projection uncertainty and cross-validate the halves (CalibrationResult's
  /// uncertainty and halves; two more fits). Off for a first fit that only has to explain the
  /// corners where they were seen.
  bool judge_whole_image = true;
};

using autocal::CameraIntrinsics;

struct DroppedView {
  int index = -1;  ///< index into the input views
  std::string reason;
};

struct CalibrationResult {
  CameraIntrinsics intrinsics;
  double rms_px = 0;                       ///< over all used corners
  /// Over every corner of the used views, the dropped ones too, each view at its fitted pose and
  /// each corner's residual counted up to CalibrationOptions::model_corner_cap_factor times
  /// rms_px: how well the model explains the corners, outliers included (a model that does not
  /// fit the lens drops the corners it cannot explain, which lowers rms_px but not this; a corner
  /// detected wrong counts about the same for every model, so none wins by bending towards it)
  /// [px].
  double all_corners_rms_px = 0;
  std::vector<int> used_views;             ///< indices into the input views
  std::vector<double> per_view_rms_px;     ///< parallel to used_views
  std::vector<DroppedView> dropped_views;  ///< outliers, with the reason
  int dropped_corners = 0;
  /// Standard deviations [fx fy cx cy, then the distortion terms in their order]; fixed terms 0.
  /// For equidistant they come from the fit's covariance (OpenCV does not report them).
  std::vector<double> std_devs;
  /// Which distortion terms were fitted, e.g. "k1 k2 p1 p2 (k3 fixed at 0)".
  std::string fitted_terms;
  int term_set = 0;  ///< the index of fitted_terms among the model's term sets (0 the simplest)
  /// Held-out RMS of the chosen term set during kHoldout selection [px] (0 otherwise).
  double selection_holdout_rms_px = 0;
  /// Why the terms were chosen, e.g. "k3 = 0.16 +- 0.13 (t 1.3 < 3): fixed".
  std::string selection_reason;
  /// How sure the result is of its projection over the whole image.
  ProjectionUncertainty uncertainty;
  /// The fits of the two halves of the used views compared (not valid under 8 views).
  HalvesCrossValidation halves;
  /// The lens models tried before this one and not chosen (calibrateChoosingModel), each with its
  /// reasons: "plumb_bob: ..."; empty when the first model was chosen.
  std::string refused_models;
};

/// Calibrates from views (corners in pattern order). Throws InputError for unusable corners (NaN,
/// wrong count) and CalibrationError when the views cannot determine the model (too few, all
/// alike, too many outliers), each with a message naming the reason.
CalibrationResult calibrate(const std::vector<std::vector<cv::Point2f>>& views,
                            const cv::Size& image_size, const BoardSpec& board,
                            const CalibrationOptions& options);

struct HoldoutEvaluation {
  double mean_rms_px = 0;           ///< mean over folds of the held-out view's RMS
  std::vector<double> fold_rms_px;  ///< per fold (= per held-out view)
  std::vector<double> fold_fx_px;   ///< fx fitted in each fold
  double fx_spread_px = 0;          ///< max − min of fold_fx_px
};

/// How the folds are fitted: autocal's calibrate(), or plain cv::calibrateCamera with default
/// flags (k1 k2 p1 p2 k3, no outlier handling) as the baseline.
enum class HoldoutMethod { kAutocal, kPlainOpenCv };

/// Leave-one-out: for each view, fit on all the others, fit the held-out view's pose with those
/// intrinsics and measure its reprojection RMS.
HoldoutEvaluation leaveOneOut(const std::vector<std::vector<cv::Point2f>>& views,
                              const cv::Size& image_size, const BoardSpec& board,
                              const CalibrationOptions& options, HoldoutMethod method);

struct QualityGateOptions {
  double max_rms_px = 1.0;
  double max_view_rms_px = 2.0;
  int min_views = 8;
  /// Largest standard deviation of fx (and of fy) relative to its value.
  double max_focal_rel_std = 0.02;
  /// Principal point within this fraction of the image size from the centre.
  double max_principal_offset_ratio = 0.2;
  /// Largest projection uncertainty (1 sigma, worst direction) over the lower half of the image,
  /// where a lane follower looks at the floor [px]; a grid cell the model maps no ray to fails it.
  /// Boards seen only in a band across the upper half leave it tens of pixels; OpenCV's left*.jpg,
  /// whose boards fill the middle of the image, 2.6 px (the views' own scatter, 1.6 px with the
  /// corners' noise taken as independent).
  double max_lower_half_uncertainty_px = 3.0;
  /// Largest ratio of the difference between two calibrations from alternate halves of the views
  /// to what their uncertainties allow (HalvesCrossValidation::ratio): about 1 when the model fits
  /// the lens, above about 2 when it does not (mrcal's rule of thumb); measured against each
  /// half's uncertainty with the corners' noise taken as independent. Real lenses fitted with
  /// plumb_bob come near 3 (OpenCV's left*.jpg: 2.4 to 2.8, from 6 and 7 views), so the default
  /// refuses only a clear misfit. Judged only when each half holds min_views_per_half views: a
  /// half of a few views is too weak a fit for its uncertainty to mean much (left01-09: 4.0 from
  /// 4 and 5).
  double max_halves_ratio = 4.0;
  int min_views_per_half = 10;
  /// How far the written model may project from the model the views fit best, where that one is
  /// not listed (calibrateChoosingModel), anywhere over the image grid [px].
  double max_model_difference_px = 1.0;
};

/// Reasons the result may not be written; empty when it passes.
std::vector<std::string> checkQuality(const CalibrationResult& result,
                                      const QualityGateOptions& gate);

/// Whether a fit with projection uncertainty `candidate` is much surer than one with `current`:
/// its RMS over the image lower by more than `margin` (a fraction), or its worst cell lower by
/// more than `margin` and less than half of the other's, with the RMS no higher (margin 1: never). A rational fit of a fisheye lens in the robustness
/// matrix had the equidistant fit's RMS within 18 % but five times its worst cell, and was 1.7 px
/// off in a corner; on OpenCV's left*.jpg, plumb_bob's worst cell is 1.6 times equidistant's and
/// plumb_bob is kept. An invalid uncertainty is never surer, and a valid one is surer than an
/// invalid one.
bool muchSurer(const ProjectionUncertainty& candidate, const ProjectionUncertainty& current,
               double margin);

/// The lens model that fits: options.model and each of options.fallback_models, fitted to the same
/// views and judged by the same gate (over the whole image too: the uncertainty, the unmapped
/// cells, the halves' cross-validation). Of the models the gate passes, those that explain the
/// corners as well as the best (CalibrationOptions::model_rms_margin) are eligible; the first
/// eligible one is chosen unless a later one is much surer of its projection
/// (model_uncertainty_margin). A model that passes the gate may still not fit the lens where no
/// view shows it: the simulator's fisheye lens, seen over most of the image, passed the gate with
/// rational_polynomial, its corners explained as well as by equidistant, its uncertainty twice
/// as large, and 22 px off at the image's corner. The models not listed are fitted too, as
/// references: when one of them is the best by the same rule, the chosen model is refused where
/// it projects more than QualityGateOptions::max_model_difference_px from it anywhere over the
/// image, and the refusal says within which radius of the image centre it stays within that.
struct ModelChoice {
  struct Refusal {
    DistortionModel model = DistortionModel::kPlumbBob;
    /// The gate's, why the fit failed, or why a model the gate passed was set aside.
    std::vector<std::string> reasons;
  };
  bool passed = false;
  CalibrationResult result;      ///< the chosen model's (when passed)
  /// The models tried before the chosen one and not chosen, in order (all of them when none
  /// passed).
  std::vector<Refusal> refused;
  /// The refusals as text: with one model its reasons joined by `separator`; with several, each
  /// "<model>: <reasons>" joined by `separator`.
  std::string refusals(const std::string& separator) const;
};
/// Throws InputError for unusable corners, CalibrationError when the first model's fit fails (a
/// fallback's failed fit is a refusal).
ModelChoice calibrateChoosingModel(const std::vector<std::vector<cv::Point2f>>& views,
                                   const cv::Size& image_size, const BoardSpec& board,
                                   const CalibrationOptions& options,
                                   const QualityGateOptions& gate);

}  // namespace camera
}  // namespace autocal
