#include "homography_teach_repeat/eval/recorded_sequence.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <optional>
#include <sstream>

namespace homography_teach_repeat {
namespace eval {
namespace {

Status invalid(const std::string& message) { return Status(StatusCode::kInvalidInput, message); }

std::string numbered(int index, int width, const std::string& extension) {
  std::ostringstream name;
  name << std::setw(width) << std::setfill('0') << index << extension;
  return name.str();
}

// Every number of a text file, line by line (blank lines skipped).
Expected<std::vector<std::vector<double>>> readNumberLines(const std::string& path, std::size_t numbers_per_line) {
  std::ifstream in(path);
  if (!in) return invalid("cannot open '" + path + "'");
  std::vector<std::vector<double>> lines;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream fields(line);
    std::vector<double> values;
    double value = 0.0;
    while (fields >> value) values.push_back(value);
    if (values.size() != numbers_per_line || !fields.eof()) {
      return invalid("'" + path + "' line " + std::to_string(line_number) + ": expected " +
                     std::to_string(numbers_per_line) + " numbers");
    }
    for (const double v : values) {
      if (!std::isfinite(v)) return invalid("'" + path + "' line " + std::to_string(line_number) + ": not finite");
    }
    lines.push_back(std::move(values));
  }
  return lines;
}

Expected<cv::Mat> readGreyImage(const std::string& path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) return invalid("cannot read image '" + path + "'");
  return image;
}

// Ground-truth cameras -> the sequence's level frames and planar ground truth.
void setLevelGroundTruth(const LevelTrajectory& level, RecordedSequence* sequence) {
  for (std::size_t i = 0; i < level.planar.size() && i < sequence->stamps.size(); ++i) {
    sequence->ground_truth.push_back({sequence->stamps[i], level.planar[i]});
  }
  // A robot without an IMU: the mount measured once, standing at the start.
  sequence->mount_camera_to_level = level.camera_to_level.front();
  sequence->mount_source =
      "level camera = base_link; constant mount tilt: the first frame's tilt from the ground truth's level frame";
}

// The normal of the plane the camera centres move in (least squares), signed like `mean_down`;
// none where the centres do not span a plane (fewer than three, on a line, or spread across the
// best plane by more than kThickest of their spread along its second axis: a normal uncertain by
// more than about 3°) or where that plane is steeper than a floor (kSteepest from `mean_down`).
std::optional<Eigen::Vector3d> motionPlaneNormal(const std::vector<Eigen::Vector3d>& centres,
                                                 const Eigen::Vector3d& mean_down) {
  constexpr double kThickest = 0.05;
  constexpr double kSteepest = 0.26;  // [rad] (15°)
  if (centres.size() < 3) return std::nullopt;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : centres) mean += c;
  mean /= static_cast<double>(centres.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& c : centres) scatter += (c - mean) * (c - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);  // eigenvalues ascending
  if (solver.info() != Eigen::Success || !(solver.eigenvalues()(1) > 0.0) ||
      solver.eigenvalues()(0) > kThickest * kThickest * solver.eigenvalues()(1)) {
    return std::nullopt;
  }
  Eigen::Vector3d normal = solver.eigenvectors().col(0).normalized();
  if (normal.dot(mean_down) < 0.0) normal = -normal;
  if (normal.dot(mean_down) < std::cos(kSteepest)) return std::nullopt;
  return normal;
}

}  // namespace

Eigen::Matrix3d levelAxes(const Eigen::Matrix3d& camera_to_world, const Eigen::Vector3d& down) {
  const Eigen::Vector3d y = down.normalized();
  const Eigen::Vector3d z = (camera_to_world.col(2) - camera_to_world.col(2).dot(y) * y).normalized();
  Eigen::Matrix3d axes;
  axes.col(1) = y;
  axes.col(2) = z;
  axes.col(0) = y.cross(z);
  return axes;
}

LevelTrajectory levelTrajectory(const std::vector<Eigen::Matrix3d>& camera_to_world,
                                const std::vector<Eigen::Vector3d>& centres, LevelTo level_to) {
  LevelTrajectory result;
  if (camera_to_world.empty() || camera_to_world.size() != centres.size()) return result;
  Eigen::Vector3d mean_y = Eigen::Vector3d::Zero();
  for (const auto& R : camera_to_world) mean_y += R.col(1);
  result.down = mean_y.normalized();
  const auto motion_normal =
      level_to == LevelTo::kMotionPlane ? motionPlaneNormal(centres, result.down) : std::nullopt;
  if (motion_normal) result.down = *motion_normal;
  const Eigen::Matrix3d first = levelAxes(camera_to_world.front(), result.down);
  for (std::size_t i = 0; i < camera_to_world.size(); ++i) {
    const Eigen::Matrix3d axes = levelAxes(camera_to_world[i], result.down);
    result.camera_to_level.push_back(axes.transpose() * camera_to_world[i]);
    // In the first level frame: x right, y down, z forward -> REP-103 x forward, y left.
    const Eigen::Vector3d c = first.transpose() * (centres[i] - centres.front());
    const Eigen::Vector3d forward = first.transpose() * axes.col(2);
    result.planar.emplace_back(c.z(), -c.x(), std::atan2(-forward.x(), forward.z()));
    result.height.push_back(-c.y());
  }
  return result;
}

std::string strechaImageName(int index) { return numbered(index, 4, ".jpg"); }

Expected<GroundTruthCamera> readStrechaCamera(const std::string& path) {
  std::ifstream in(path);
  if (!in) return invalid("cannot open ground-truth camera '" + path + "'");
  GroundTruthCamera camera;
  double distortion[3];
  for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) in >> camera.K(r, c);
  for (double& d : distortion) in >> d;
  for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) in >> camera.R(r, c);
  in >> camera.C(0) >> camera.C(1) >> camera.C(2) >> camera.width >> camera.height;
  if (!in || !camera.K.allFinite() || !camera.R.allFinite() || !camera.C.allFinite() || camera.width <= 0 ||
      camera.height <= 0) {
    return invalid("ground-truth camera '" + path + "' is truncated or malformed");
  }
  return camera;
}

Expected<RecordedSequence> readKittiSequence(const std::string& directory, const std::string& poses_file) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(directory)) return invalid("KITTI folder '" + directory + "' does not exist");
  RecordedSequence sequence;
  int count = 0;
  while (fs::exists(directory + "/image_0/" + numbered(count, 6, ".png"))) ++count;
  if (count < 2) {
    return invalid("KITTI folder '" + directory + "': image_0/ holds " + std::to_string(count) +
                   " images (000000.png, 000001.png, ...); at least 2 are needed");
  }
  // calib.txt: "P0: 12 numbers" (the left grey camera).
  const std::string calib_path = directory + "/calib.txt";
  std::ifstream calib(calib_path);
  if (!calib) return invalid("KITTI folder '" + directory + "' has no calib.txt");
  std::string line;
  Eigen::Matrix<double, 3, 4> P;
  bool found = false;
  while (std::getline(calib, line)) {
    if (line.rfind("P0:", 0) != 0) continue;
    std::istringstream fields(line.substr(3));
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 4; ++c) fields >> P(r, c);
    found = static_cast<bool>(fields) && P.allFinite() && P(0, 0) > 0.0 && P(1, 1) > 0.0;
  }
  if (!found) return invalid("'" + calib_path + "' has no valid 'P0:' line (12 numbers, fx, fy > 0)");

  const auto times = readNumberLines(directory + "/times.txt", 1);
  if (!times) return times.status();
  if (static_cast<int>(times->size()) < count) {
    return invalid("'" + directory + "/times.txt' has " + std::to_string(times->size()) + " stamps for " +
                   std::to_string(count) + " images");
  }
  for (int i = 0; i < count; ++i) sequence.stamps.push_back((*times)[static_cast<std::size_t>(i)][0]);
  for (int i = 1; i < count; ++i) {
    if (!(sequence.stamps[i] > sequence.stamps[i - 1])) {
      return invalid("'" + directory + "/times.txt': stamps do not increase at line " + std::to_string(i + 1));
    }
  }

  std::string poses_path = poses_file;
  if (poses_path.empty()) {
    std::vector<std::string> candidates;
    for (const auto& entry : fs::directory_iterator(directory)) {
      const std::string name = entry.path().filename().string();
      std::string lower = name;
      std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
      if (entry.path().extension() == ".txt" && lower != "calib.txt" && lower != "times.txt" &&
          lower.rfind("readme", 0) != 0) {
        candidates.push_back(entry.path().string());
      }
    }
    if (candidates.size() != 1) {
      return invalid("KITTI folder '" + directory + "': " + std::to_string(candidates.size()) +
                     " candidate poses files (*.txt other than calib.txt and times.txt); name one");
    }
    poses_path = candidates.front();
  }
  const auto poses = readNumberLines(poses_path, 12);
  if (!poses) return poses.status();
  if (static_cast<int>(poses->size()) < count) {
    return invalid("ground truth '" + poses_path + "' has " + std::to_string(poses->size()) + " poses for " +
                   std::to_string(count) + " images");
  }
  std::vector<Eigen::Matrix3d> rotations;
  std::vector<Eigen::Vector3d> centres;
  for (int i = 0; i < count; ++i) {
    const auto& v = (*poses)[static_cast<std::size_t>(i)];
    Eigen::Matrix3d R;
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) R(r, c) = v[4 * static_cast<std::size_t>(r) + static_cast<std::size_t>(c)];
    if (std::abs(R.determinant() - 1.0) > 1e-3 || !(R.transpose() * R).isIdentity(1e-3)) {
      return invalid("ground truth '" + poses_path + "' line " + std::to_string(i + 1) + " is not a rotation");
    }
    rotations.push_back(R);
    centres.emplace_back(v[3], v[7], v[11]);
  }
  const LevelTrajectory level = levelTrajectory(rotations, centres);

  CameraCalibration camera;
  camera.fx = P(0, 0);
  camera.fy = P(1, 1);
  camera.cx = P(0, 2);
  camera.cy = P(1, 2);
  {
    const auto first = readGreyImage(directory + "/image_0/" + numbered(0, 6, ".png"));
    if (!first) return first.status();
    camera.width = first->cols;
    camera.height = first->rows;
  }
  sequence.description = "KITTI odometry layout '" + directory + "', " + std::to_string(count) +
                         " images, ground truth '" + poses_path + "'";
  setLevelGroundTruth(level, &sequence);
  const auto tilts = level.camera_to_level;
  sequence.load_image = [directory, camera, tilts](int index) -> Expected<SequenceImage> {
    auto image = readGreyImage(directory + "/image_0/" + numbered(index, 6, ".png"));
    if (!image) return image.status();
    if (image->cols != camera.width || image->rows != camera.height) {
      return invalid("image " + std::to_string(index) + " is " + std::to_string(image->cols) + "x" +
                     std::to_string(image->rows) + ", the first was " + std::to_string(camera.width) + "x" +
                     std::to_string(camera.height));
    }
    return SequenceImage{*image, camera, tilts[static_cast<std::size_t>(index)]};
  };
  return sequence;
}

Expected<RecordedSequence> readStrechaSequence(const std::string& directory) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(directory)) return invalid("Strecha folder '" + directory + "' does not exist");
  int count = 0;
  while (fs::exists(directory + "/images/" + strechaImageName(count))) ++count;
  if (count < 2) {
    return invalid("Strecha folder '" + directory + "' holds " + std::to_string(count) +
                   " views (images/0000.jpg, 0001.jpg, ...); at least 2 are needed");
  }
  std::vector<GroundTruthCamera> cameras;
  std::vector<Eigen::Matrix3d> rotations;
  std::vector<Eigen::Vector3d> centres;
  RecordedSequence sequence;
  for (int i = 0; i < count; ++i) {
    auto camera = readStrechaCamera(directory + "/gt_dense_cameras/" + strechaImageName(i) + ".camera");
    if (!camera) return camera.status();
    cameras.push_back(*camera);
    rotations.push_back(camera->R);
    centres.push_back(camera->C);
    sequence.stamps.push_back(0.1 * i);
  }
  const LevelTrajectory level = levelTrajectory(rotations, centres);
  sequence.description = "Strecha set '" + directory + "', " + std::to_string(count) + " views";
  setLevelGroundTruth(level, &sequence);
  const auto tilts = level.camera_to_level;
  sequence.load_image = [directory, cameras, tilts](int index) -> Expected<SequenceImage> {
    auto image = readGreyImage(directory + "/images/" + strechaImageName(index));
    if (!image) return image.status();
    const GroundTruthCamera& gt = cameras[static_cast<std::size_t>(index)];
    if (image->cols != gt.width || image->rows != gt.height) {
      return invalid("view " + std::to_string(index) + " is " + std::to_string(image->cols) + "x" +
                     std::to_string(image->rows) + ", its camera file says " + std::to_string(gt.width) + "x" +
                     std::to_string(gt.height));
    }
    CameraCalibration camera;
    camera.width = gt.width;
    camera.height = gt.height;
    camera.fx = gt.K(0, 0);
    camera.fy = gt.K(1, 1);
    camera.cx = gt.K(0, 2);
    camera.cy = gt.K(1, 2);
    return SequenceImage{*image, camera, tilts[static_cast<std::size_t>(index)]};
  };
  return sequence;
}

}  // namespace eval
}  // namespace homography_teach_repeat
