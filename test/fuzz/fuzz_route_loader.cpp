// libFuzzer target: the route loader on arbitrary file contents. The first byte picks the file of
// a valid two-keyframe route that the rest of the input replaces (route.yaml, or keyframe 0's
// image, features or lines file); loadRoute and the per-keyframe loaders must give a status,
// never crash, hang or read out of bounds.
#include <opencv2/imgproc.hpp>

#include "fuzz_support.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace htr = homography_teach_repeat;

namespace {

struct ValidRoute {
  std::string directory;
  std::vector<std::string> files;     // route.yaml, keyframe 0's image, features, lines
  std::vector<std::string> contents;  // their valid contents
};

ValidRoute makeRoute() {
  ValidRoute valid;
  valid.directory = htr_fuzz::scratchDirectory() + "/route";
  htr::RouteInfo info;
  info.feature_type = htr::FeatureType::kOrb;
  info.camera.width = 64;
  info.camera.height = 48;
  info.camera.fx = info.camera.fy = 50.0;
  info.camera.cx = 31.5;
  info.camera.cy = 23.5;
  auto writer = htr::RouteWriter::create(valid.directory, info, true);
  if (!writer) throw std::runtime_error(writer.status().toString());
  cv::Mat image(48, 64, CV_8UC1, cv::Scalar(60));
  image.colRange(30, 64).setTo(200);  // one vertical edge
  htr::ImageFeatures features;
  features.type = htr::FeatureType::kOrb;
  features.keypoints = {cv::KeyPoint(10.f, 20.f, 31.f), cv::KeyPoint(40.f, 12.f, 31.f)};
  features.descriptors = cv::Mat(2, 32, CV_8UC1, cv::Scalar(7));
  htr::VerticalLineExtractor extractor;
  const auto lines = extractor.extract(image);
  if (!lines) throw std::runtime_error(lines.status().toString());
  for (int k = 0; k < 2; ++k) {
    const auto status = writer->addKeyframe(image, features, *lines, htr::Pose2D(0.5 * k, 0.0, 0.0), 1.0 + k);
    if (!status.isOk()) throw std::runtime_error(status.toString());
  }
  // What the teach run measures (docs/route_format.md, "Measured noise"), so that its fields are
  // in the index the fuzzer mutates.
  const htr::ScenePlane wall{Eigen::Vector3d::UnitZ(), 3.0};
  htr::PlaneUncertainty uncertainty{0.02, 0.03, Eigen::Vector3d(0.5, -0.2, 3.0), Eigen::Matrix3d::Identity() * 1e-4,
                                    -2e-4};
  for (const auto& status :
       {writer->setMeasuredNoise({htr::MatchResidual{0.3, 40}, std::nullopt}, {htr::PairTilt{0.001, -0.002}, std::nullopt}),
        writer->setPlanes({wall, wall}, 0.0), writer->setPlaneUncertainties({uncertainty, uncertainty})}) {
    if (!status.isOk()) throw std::runtime_error(status.toString());
  }
  const htr::RouteKeyframe& first = writer->route().keyframes.at(0);
  for (const std::string& file : {std::string("route.yaml"), first.image_file, first.features_file, first.lines_file}) {
    valid.files.push_back(valid.directory + "/" + file);
    valid.contents.push_back(htr_fuzz::readFile(valid.files.back()));
  }
  return valid;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const ValidRoute valid = makeRoute();
  if (size < 1) return 0;
  const std::size_t which = data[0] % valid.files.size();
  htr_fuzz::writeFile(valid.files[which], data + 1, size - 1);
  const auto route = htr::loadRoute(valid.directory);
  if (route) {
    for (std::size_t k = 0; k < route->keyframes.size(); ++k) {
      (void)htr::loadKeyframeImage(*route, k);
      (void)htr::loadKeyframeFeatures(*route, k);
      (void)htr::loadKeyframeLines(*route, k);
    }
  }
  const std::string& original = valid.contents[which];
  htr_fuzz::writeFile(valid.files[which], reinterpret_cast<const std::uint8_t*>(original.data()), original.size());
  return 0;
}
