// A Strecha multi-view set (e.g. ../shared/realdata/strecha_fountain/fountain-P11: 11 photos of a
// wall with ground-truth cameras, see its README; any number of views, images/NNNN.jpg and
// gt_dense_cameras/NNNN.jpg.camera counted from 0000) as the evaluation programs use it: images
// downscaled to robot resolution, and every camera's gravity alignment (a rotation to a level
// virtual camera whose y axis is the views' mean "down", LevelTo::kMeanCameraAxis; the role of a robot's camera mount
// or IMU). Only the tilt of each camera comes from the ground truth here; evaluations take
// headings and positions from it only to score.
#pragma once

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/eval/recorded_sequence.h"

namespace homography_teach_repeat {
namespace eval {

inline std::string fountainImageName(int index) { return strechaImageName(index); }

inline GroundTruthCamera readGroundTruthCamera(const std::string& path, const cli::Arguments& args) {
  auto camera = readStrechaCamera(path);
  if (!camera) args.fail(camera.status().message());
  return *camera;
}

struct FountainView {
  GroundTruthCamera gt;
  Eigen::Matrix3d level;          // columns: level axes in world (y = mean down)
  Eigen::Matrix3d rectification;  // pixel map of the scaled image to the level camera: K Q K⁻¹
  double tilt_deg = 0.0;          // angle of Q
  cv::Mat image;                  // grey, scaled
};

class FountainSequence {
 public:
  // Reads the views 0000, 0001, ... up to the first index without an image; fewer than 2 views,
  // or an image without its camera file, stop the program with a message naming the file.
  FountainSequence(const std::string& dir, double scale, const cli::Arguments& args) {
    int count = 0;
    while (std::filesystem::exists(dir + "/images/" + fountainImageName(count))) ++count;
    if (count < 2) {
      args.fail("'" + dir + "' holds " + std::to_string(count) +
                " views (images/0000.jpg, 0001.jpg, ...); at least 2 are needed");
    }
    views_.resize(count);
    for (int i = 0; i < count; ++i) {
      views_[i].gt = readGroundTruthCamera(
          dir + "/gt_dense_cameras/" + fountainImageName(i) + ".camera", args);
    }
    std::vector<Eigen::Matrix3d> rotations;
    std::vector<Eigen::Vector3d> centres;
    for (const auto& v : views_) {
      rotations.push_back(v.gt.R);
      centres.push_back(v.gt.C);
    }
    // The photographs' gravity (their mean axis), not the plane their centres move in (2.7° off it
    // on fountain-P11's sloping ground): these programs check the estimators against the world's
    // vertical (μ's vertical edges), where evaluate_sequence emulates a robot on its floor.
    const LevelTrajectory level = levelTrajectory(rotations, centres, LevelTo::kMeanCameraAxis);
    K_ = views_[0].gt.K;
    K_(0, 0) *= scale;
    K_(1, 1) *= scale;
    K_(0, 2) = (K_(0, 2) + 0.5) * scale - 0.5;  // pixel centres preserved
    K_(1, 2) = (K_(1, 2) + 0.5) * scale - 0.5;
    calibration_.width = static_cast<int>(std::lround(views_[0].gt.width * scale));
    calibration_.height = static_cast<int>(std::lround(views_[0].gt.height * scale));
    calibration_.fx = K_(0, 0);
    calibration_.fy = K_(1, 1);
    calibration_.cx = K_(0, 2);
    calibration_.cy = K_(1, 2);
    for (int i = 0; i < count; ++i) {
      FountainView& v = views_[i];
      const std::string path = dir + "/images/" + fountainImageName(i);
      cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
      if (image.empty()) args.fail("cannot read image '" + path + "'");
      cv::resize(image, v.image, cv::Size(calibration_.width, calibration_.height), 0, 0,
                 cv::INTER_AREA);
      v.level = levelAxes(v.gt.R, level.down);
      const Eigen::Matrix3d& Q = level.camera_to_level[static_cast<std::size_t>(i)];  // camera -> level
      v.rectification = K_ * Q * K_.inverse();
      v.tilt_deg = Eigen::AngleAxisd(Q).angle() * 180.0 / M_PI;
    }
  }

  const std::vector<FountainView>& views() const { return views_; }
  int size() const { return static_cast<int>(views_.size()); }
  const Eigen::Matrix3d& K() const { return K_; }
  const CameraCalibration& calibration() const { return calibration_; }

  // Ground-truth pose of level camera j in the level frame of camera i (x, z; the height
  // difference is returned separately), θ = θ12 of docs/math.md §1.1.
  PlanarPose relativePose(int i, int j, double* height_offset = nullptr) const {
    const FountainView& a = views_[i];
    const FountainView& b = views_[j];
    const Eigen::Vector3d c = a.level.transpose() * (b.gt.C - a.gt.C);
    const Eigen::Vector3d axis = a.level.transpose() * b.level.col(2);
    if (height_offset != nullptr) *height_offset = c.y();
    return PlanarPose(c.x(), c.z(), std::atan2(-axis.x(), axis.z()));
  }

  // The wall fitted to points triangulated with the ground-truth cameras i, j from raw (scaled,
  // unrectified) pixel matches: nᵀX = offset (world), robust to off-wall points (3 rounds
  // dropping points beyond 3 median absolute residuals).
  std::pair<Eigen::Vector3d, double> fitWall(int i, int j, const PointMatches& raw) const {
    cv::Mat p0(2, static_cast<int>(raw.size()), CV_64F), p1(2, static_cast<int>(raw.size()), CV_64F);
    for (std::size_t k = 0; k < raw.size(); ++k) {
      p0.at<double>(0, k) = raw[k].reference.x();
      p0.at<double>(1, k) = raw[k].reference.y();
      p1.at<double>(0, k) = raw[k].current.x();
      p1.at<double>(1, k) = raw[k].current.y();
    }
    cv::Mat P0(3, 4, CV_64F), P1(3, 4, CV_64F), X;
    const Eigen::Matrix<double, 3, 4> e0 = projection(views_[i].gt), e1 = projection(views_[j].gt);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) {
        P0.at<double>(r, c) = e0(r, c);
        P1.at<double>(r, c) = e1(r, c);
      }
    }
    cv::triangulatePoints(P0, P1, p0, p1, X);
    std::vector<Eigen::Vector3d> points;
    for (int k = 0; k < X.cols; ++k) {
      const double w = X.at<double>(3, k);
      points.emplace_back(X.at<double>(0, k) / w, X.at<double>(1, k) / w, X.at<double>(2, k) / w);
    }
    std::vector<Eigen::Vector3d> kept = points;
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
    double offset = 0.0;
    for (int round = 0; round < 3 && kept.size() >= 3; ++round) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const auto& p : kept) mean += p;
      mean /= static_cast<double>(kept.size());
      Eigen::MatrixXd centred(kept.size(), 3);
      for (std::size_t k = 0; k < kept.size(); ++k) centred.row(k) = (kept[k] - mean).transpose();
      const Eigen::JacobiSVD<Eigen::MatrixXd> svd(centred, Eigen::ComputeThinV);
      normal = svd.matrixV().col(2);
      offset = normal.dot(mean);
      std::vector<double> residuals;
      for (const auto& p : points) residuals.push_back(std::abs(normal.dot(p) - offset));
      std::vector<double> sorted = residuals;
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      const double limit = 3.0 * sorted[sorted.size() / 2];
      kept.clear();
      for (std::size_t k = 0; k < points.size(); ++k) {
        if (residuals[k] <= limit) kept.push_back(points[k]);
      }
    }
    return {normal, offset};
  }

 private:
  Eigen::Matrix<double, 3, 4> projection(const GroundTruthCamera& cam) const {
    Eigen::Matrix<double, 3, 4> P;
    P.leftCols<3>() = cam.R.transpose();
    P.col(3) = -cam.R.transpose() * cam.C;
    return K_ * P;
  }

  std::vector<FountainView> views_;
  Eigen::Matrix3d K_;
  CameraCalibration calibration_;
};

}  // namespace eval
}  // namespace homography_teach_repeat
