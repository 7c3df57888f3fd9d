// The per-frame heading correction of the μ mode (paper 002): vertical lines of the current image
// matched against those of a reference keyframe, robust 1D homography (LMedS), heading from μ.
// The repeat node and the calibration tool call this; every failure is a status, never an angle.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/mu/heading_1d.h"
#include "homography_teach_repeat/mu/homography_1d.h"
#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/vertical_line_matcher.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace homography_teach_repeat {

struct HeadingCorrectionOptions {
  LineMatchOptions matching;
  Homography1dOptions homography;
  int min_inliers = 5;  // fewer agreeing lines than this: kNoConsensus
  // LMedS scales its threshold with the median residual, so on unrelated lines it would accept
  // anything: a noise estimate σ̂ above this [px] is reported as kNoConsensus.
  double max_sigma_px = 3.0;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct HeadingCorrection {
  double theta = 0.0;  // θ12 [rad] from μ: the current camera's yaw relative to the reference
  double mu = 0.0;     // h12/h22 of the centred H [px]
  Eigen::Matrix2d H = Eigen::Matrix2d::Identity();
  int line_matches = 0;
  int inliers = 0;
  double sigma_px = 0.0;  // σ̂ of the LMedS fit
};

class HeadingCorrector {
 public:
  // Throws std::invalid_argument on invalid options or camera.
  HeadingCorrector(const HeadingCorrectionOptions& options, const LineCamera& camera);

  // Status: kTooFewPoints (fewer than 3 line matches: e.g. no vertical structure, or the lines of
  // the two images have opposite polarities), kNoConsensus (fewer than min_inliers agree),
  // or σ̂ > max_sigma_px), kDegenerate, kInvalidInput (non-finite lines).
  // `predicted_theta` [rad] (e.g. from odometry): the reference lines are moved by that rotation
  // before matching (guided matching: the matcher prefers small disparities, so a rotation of
  // several degrees otherwise pairs lines with their neighbours and μ comes out too small — in
  // the simulator 1.5° for a true 6.9°). The 1D homography is fitted to the original positions.
  Expected<HeadingCorrection> estimate(const std::vector<VerticalLine>& reference,
                                       const std::vector<VerticalLine>& current,
                                       double predicted_theta = 0.0) const;
  // The same guided by a predicted centred 1D homography (reference -> current x, docs/math.md §4.4),
  // e.g. the keyframe's wall at the pose the odometry predicts (wallHomography1dAt): it moves the
  // lines by the lateral offset and the depth change too, not only by the rotation. On periodic
  // structure (a calibration board, a grid of windows) a lateral offset of one period otherwise
  // pairs every line with its neighbour, consistently from frame to frame (measured in the
  // simulator: μ 80-120 px off on every fix against a chessboard 1.9 m away).
  Expected<HeadingCorrection> estimate(const std::vector<VerticalLine>& reference,
                                       const std::vector<VerticalLine>& current,
                                       const Eigen::Matrix2d& predicted_centred_H) const;

 private:
  HeadingCorrectionOptions options_;
  LineCamera camera_;
};

}  // namespace homography_teach_repeat
