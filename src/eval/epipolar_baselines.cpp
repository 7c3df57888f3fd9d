#include "homography_teach_repeat/eval/epipolar_baselines.h"

#include <opencv2/calib3d.hpp>

#include <cmath>
#include <string>
#include <vector>

namespace homography_teach_repeat {
namespace {

void toCvPoints(const PointMatches& matches, std::vector<cv::Point2d>* reference,
                std::vector<cv::Point2d>* current) {
  reference->clear();
  current->clear();
  for (const auto& m : matches) {
    reference->emplace_back(m.reference.x(), m.reference.y());
    current->emplace_back(m.current.x(), m.current.y());
  }
}

cv::Matx33d toCv(const Eigen::Matrix3d& m) {
  cv::Matx33d out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = m(r, c);
  }
  return out;
}

// recoverPose on one essential matrix (3x3 CV_64F).
EpipolarMotion recover(const cv::Mat& essential, const std::vector<cv::Point2d>& reference,
                       const std::vector<cv::Point2d>& current, const cv::Matx33d& K) {
  cv::Mat R, t;
  EpipolarMotion motion;
  motion.cheirality_inliers = cv::recoverPose(essential, reference, current, cv::Mat(K), R, t);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) motion.rotation21(r, c) = R.at<double>(r, c);
    motion.translation_direction(r) = t.at<double>(r);
  }
  return motion;
}

bool isFinite(const EpipolarMotion& m) {
  return m.rotation21.allFinite() && m.translation_direction.allFinite();
}

}  // namespace

PlanarPose EpipolarMotion::planarPose(double baseline) const {
  const Eigen::Vector3d centre =
      -rotation21.transpose() * translation_direction.normalized() * baseline;
  const double theta21 = std::atan2(rotation21(2, 0) - rotation21(0, 2),
                                    rotation21(0, 0) + rotation21(2, 2));
  return PlanarPose(centre.x(), centre.z(), -theta21);
}

Expected<EpipolarMotion> motionFromEightPointF(const PointMatches& matches,
                                               const PinholeCamera& camera) {
  if (matches.size() < 8) {
    return Status(StatusCode::kTooFewPoints,
                  "the 8-point algorithm needs 8 matches, got " + std::to_string(matches.size()));
  }
  std::vector<cv::Point2d> reference, current;
  toCvPoints(matches, &reference, &current);
  cv::Mat F;
  try {
    F = cv::findFundamentalMat(reference, current, cv::FM_8POINT);
  } catch (const cv::Exception& e) {
    return Status(StatusCode::kDegenerate, std::string("findFundamentalMat: ") + e.what());
  }
  if (F.rows != 3 || F.cols != 3) {
    return Status(StatusCode::kDegenerate, "the 8-point algorithm returned no F");
  }
  const cv::Matx33d K = toCv(camera.K());
  const cv::Mat E = cv::Mat(K.t()) * F * cv::Mat(K);
  const EpipolarMotion motion = recover(E, reference, current, K);
  if (!isFinite(motion)) return Status(StatusCode::kNotFinite, "8-point: non-finite motion");
  return motion;
}

Expected<EpipolarMotion> motionFromFivePointE(const PointMatches& matches,
                                              const PinholeCamera& camera, double threshold_px) {
  if (matches.size() < 5) {
    return Status(StatusCode::kTooFewPoints,
                  "the 5-point algorithm needs 5 matches, got " + std::to_string(matches.size()));
  }
  std::vector<cv::Point2d> reference, current;
  toCvPoints(matches, &reference, &current);
  const cv::Matx33d K = toCv(camera.K());
  cv::Mat E;
  try {
    E = cv::findEssentialMat(reference, current, cv::Mat(K), cv::RANSAC, 0.999, threshold_px);
  } catch (const cv::Exception& e) {
    return Status(StatusCode::kDegenerate, std::string("findEssentialMat: ") + e.what());
  }
  if (E.cols != 3 || E.rows < 3 || E.rows % 3 != 0) {
    return Status(StatusCode::kDegenerate, "the 5-point algorithm returned no E");
  }
  EpipolarMotion best;
  best.cheirality_inliers = -1;
  for (int k = 0; k < E.rows / 3; ++k) {
    const EpipolarMotion motion = recover(E.rowRange(3 * k, 3 * k + 3).clone(), reference,
                                          current, K);
    if (isFinite(motion) && motion.cheirality_inliers > best.cheirality_inliers) best = motion;
  }
  if (best.cheirality_inliers < 0) {
    return Status(StatusCode::kNotFinite, "5-point: non-finite motion");
  }
  return best;
}

}  // namespace homography_teach_repeat
