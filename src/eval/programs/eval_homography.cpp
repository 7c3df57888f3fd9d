// eval_homography: end-to-end homography estimation on a real image pair with a ground-truth
// homography, through the core's ImageRegistration (features -> matches -> robust normalised DLT).
//
//   rosrun homography_teach_repeat eval_homography [--image1 P] [--image2 P] [--gt P]
//          [--feature sift|orb|akaze|surf] [--method lo_ransac|magsac|ransac|lmeds] [--seed S] [--json F]
//
// Defaults: graf1.png -> graf3.png and H1to3p.xml shipped by Debian's opencv-doc. The ground truth
// may be an OpenCV XML/YAML file (first matrix) or 9 numbers in plain text (Oxford/HPatches).
// Metrics: mean |H_est p − H_gt p| over the inlier reference points and over a 10 px grid of the
// overlapping region (pixels of image 2).
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>

#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/image_registration.h"

namespace htr = homography_teach_repeat;

namespace {

const std::string kDataDir = HTR_OPENCV_DATA_DIR;

[[noreturn]] void fail(const std::string& message) {
  std::cerr << "eval_homography: " << message << "\n";
  std::exit(2);
}

std::map<std::string, std::string> parseArguments(int argc, char** argv) {
  std::map<std::string, std::string> args{{"image1", kDataDir + "/graf1.png"},
                                          {"image2", kDataDir + "/graf3.png"},
                                          {"gt", kDataDir + "/H1to3p.xml"},
                                          {"feature", "sift"},
                                          {"method", "lo_ransac"},
                                          {"seed", "1"},
                                          {"max-features", "4000"},
                                          {"ratio", "0.8"},
                                          {"threshold", "1.5"},
                                          {"json", ""}};
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (key == "--help" || key == "-h") {
      std::cout << "usage: eval_homography [--image1 P] [--image2 P] [--gt P] [--feature T]\n"
                   "                       [--method M] [--max-features N] [--ratio R]\n"
                   "                       [--threshold PX]\n"
                   "                       [--seed S] [--json F]\n";
      std::exit(0);
    }
    if (key.rfind("--", 0) != 0 || i + 1 >= argc || args.count(key.substr(2)) == 0) {
      fail("unknown or incomplete argument '" + key + "' (see --help)");
    }
    args[key.substr(2)] = argv[++i];
  }
  return args;
}

}  // namespace

int main(int argc, char** argv) {
  const auto args = parseArguments(argc, argv);
  cv::setRNGSeed(std::stoi(args.at("seed")));

  const cv::Mat image1 = cv::imread(args.at("image1"), cv::IMREAD_GRAYSCALE);
  const cv::Mat image2 = cv::imread(args.at("image2"), cv::IMREAD_GRAYSCALE);
  if (image1.empty()) fail("cannot read image '" + args.at("image1") + "'");
  if (image2.empty()) fail("cannot read image '" + args.at("image2") + "'");
  const auto ground_truth = htr::readHomographyFile(args.at("gt"));
  if (!ground_truth) fail(ground_truth.status().toString());
  const Eigen::Matrix3d& H_gt = *ground_truth;

  htr::RegistrationOptions options;
  try {
    options.features.type = htr::featureTypeFromString(args.at("feature"));
    options.features.max_features = std::stoi(args.at("max-features"));
    options.matching.ratio = std::stod(args.at("ratio"));
    options.robust.inlier_threshold_px = std::stod(args.at("threshold"));
    options.robust.method = htr::robustMethodFromString(args.at("method"));
  } catch (const std::invalid_argument& e) {
    fail(e.what());
  }
  htr::ImageRegistration registration(options);

  const auto start = std::chrono::steady_clock::now();
  const htr::Status reference_status = registration.setReference(image1);
  if (!reference_status.isOk()) fail("reference: " + reference_status.toString());
  const auto result = registration.registerImage(image2);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!result) fail("registration failed: " + result.status().toString());

  const Eigen::Matrix3d& H = result->homography.H;
  double inlier_error_sum = 0.0;
  for (int i : result->homography.inliers) {
    const Eigen::Vector2d& p = result->matches[static_cast<std::size_t>(i)].reference;
    inlier_error_sum += (htr::applyHomography(H, p) - htr::applyHomography(H_gt, p)).norm();
  }
  const double mean_inlier_error =
      inlier_error_sum / static_cast<double>(result->homography.inliers.size());
  const auto grid_error =
      htr::meanGridTransferDifference(H, H_gt, image1.cols, image1.rows, image2.cols, image2.rows, 10);
  if (!grid_error) fail("grid comparison: " + grid_error.status().toString());

  std::cout << "image1: " << args.at("image1") << "\nimage2: " << args.at("image2")
            << "\nfeatures: " << result->reference_features << " / " << result->current_features
            << " (" << args.at("feature") << "), tentative matches: " << result->matches.size()
            << ", inliers: " << result->homography.inliers.size() << " (" << args.at("method")
            << ")\n"
            << "mean transfer error vs ground truth: " << mean_inlier_error
            << " px at the inliers, " << *grid_error << " px over the overlap grid\n"
            << "time: " << seconds * 1e3 << " ms (features of both images, matching, H)\n";

  if (!args.at("json").empty()) {
    nlohmann::json j;
    j["image1"] = args.at("image1");
    j["image2"] = args.at("image2");
    j["ground_truth"] = args.at("gt");
    j["feature"] = args.at("feature");
    j["method"] = args.at("method");
    j["features"] = {result->reference_features, result->current_features};
    j["tentative_matches"] = result->matches.size();
    j["inliers"] = result->homography.inliers.size();
    j["rms_inlier_transfer_error_px"] = result->homography.rms_transfer_error_px;
    j["mean_transfer_error_vs_gt_px"] = mean_inlier_error;
    j["mean_grid_transfer_error_vs_gt_px"] = *grid_error;
    j["seconds"] = seconds;
    std::ofstream out(args.at("json"));
    out << j.dump(2) << "\n";
    if (!out) fail("cannot write '" + args.at("json") + "'");
  }
  return 0;
}
