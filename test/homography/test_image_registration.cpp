#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/image_registration.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

namespace {

const std::string kOpenCvData = HTR_OPENCV_DATA_DIR;
const std::string kRealData = HTR_SHARED_REALDATA_DIR;

double registerAndCompare(const cv::Mat& reference, const cv::Mat& current,
                          const Eigen::Matrix3d& truth, FeatureType type) {
  RegistrationOptions options;
  options.features.type = type;
  options.features.max_features = 3000;
  ImageRegistration registration(options);
  EXPECT_TRUE(registration.setReference(reference).isOk());
  cv::setRNGSeed(1);
  const auto result = registration.registerImage(current);
  EXPECT_TRUE(result.isOk()) << result.status().toString();
  if (!result) return 1e9;
  return *meanGridTransferDifference(result->homography.H, truth, reference.cols, reference.rows,
                                     current.cols, current.rows, 10);
}

}  // namespace

TEST(ImageRegistration, RecoversSyntheticWarp) {
  const cv::Mat reference = test_support::makeTexture(640, 480, 9);
  const cv::Mat current = test_support::warp(reference, test_support::moderateHomography());
  EXPECT_LT(registerAndCompare(reference, current, test_support::moderateHomography(), FeatureType::kSift),
            0.3);
}

TEST(ImageRegistration, UndistortsMatchesWithTheCamera) {
  // The current image is the warped texture seen through a barrel lens; with the camera, H must
  // be that of the ideal pinhole images.
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 500.0;
  c.cx = 320.0;
  c.cy = 240.0;
  c.distortion_model = "single_parameter_radial";
  c.distortion = {-0.12};
  const PinholeCamera camera(c);
  const cv::Mat ideal_reference = test_support::makeTexture(640, 480, 10);
  const cv::Mat ideal_current = test_support::warp(ideal_reference, test_support::moderateHomography());
  // Distorted image: each distorted pixel samples the ideal image at its undistorted position.
  cv::Mat map_x(480, 640, CV_32F), map_y(480, 640, CV_32F);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const cv::Point2d p = camera.undistortPixel(cv::Point2d(u, v));
      map_x.at<float>(v, u) = static_cast<float>(p.x);
      map_y.at<float>(v, u) = static_cast<float>(p.y);
    }
  }
  cv::Mat reference, current;
  cv::remap(ideal_reference, reference, map_x, map_y, cv::INTER_LINEAR);
  cv::remap(ideal_current, current, map_x, map_y, cv::INTER_LINEAR);

  RegistrationOptions options;
  ImageRegistration registration(options);
  ASSERT_TRUE(registration.setReference(reference).isOk());
  cv::setRNGSeed(1);
  const auto with_camera = registration.registerImage(current, &camera);
  ASSERT_TRUE(with_camera.isOk()) << with_camera.status().toString();
  const double error_with = *meanGridTransferDifference(
      with_camera->homography.H, test_support::moderateHomography(), 640, 480, 640, 480, 10);
  EXPECT_LT(error_with, 0.5);
  const auto without_camera = registration.registerImage(current);
  if (without_camera.isOk()) {
    const double error_without = *meanGridTransferDifference(
        without_camera->homography.H, test_support::moderateHomography(), 640, 480, 640, 480, 10);
    EXPECT_GT(error_without, 2.0 * error_with);
  }
}

TEST(ImageRegistration, DrawsBorderAndMatches) {
  const cv::Mat reference = test_support::makeTexture(640, 480, 9);
  const cv::Mat current = test_support::warp(reference, test_support::moderateHomography());
  ImageRegistration registration{RegistrationOptions{}};
  ASSERT_TRUE(registration.setReference(reference).isOk());
  const auto result = registration.registerImage(current);
  ASSERT_TRUE(result.isOk());
  const cv::Mat canvas = drawRegistration(current, *result, reference.size());
  ASSERT_EQ(canvas.type(), CV_8UC3);
  ASSERT_EQ(canvas.size(), current.size());
  // The border is a straight line between mapped corners: the midpoint of the mapped bottom edge
  // is drawn in the border colour (blue channel dominant).
  const Eigen::Vector2d midpoint =
      0.5 * (applyHomography(result->homography.H, Eigen::Vector2d(0, 479)) +
             applyHomography(result->homography.H, Eigen::Vector2d(639, 479)));
  ASSERT_TRUE(midpoint.x() >= 0 && midpoint.x() < 640 && midpoint.y() >= 0 && midpoint.y() < 480);
  const cv::Vec3b pixel = canvas.at<cv::Vec3b>(cvRound(midpoint.y()), cvRound(midpoint.x()));
  EXPECT_GT(pixel[0], 150);
  EXPECT_LT(pixel[2], 100);
  // Some inlier marks are green.
  int green = 0;
  for (int i : result->homography.inliers) {
    const Eigen::Vector2d p = result->matches[static_cast<std::size_t>(i)].current;
    const int row = cvRound(p.y()), col = cvRound(p.x()) + 3;
    if (col >= canvas.cols) continue;
    const cv::Vec3b c = canvas.at<cv::Vec3b>(row, col);
    green += (c[1] > 150 && c[0] < 100 && c[2] < 100) ? 1 : 0;
  }
  EXPECT_GT(green, static_cast<int>(result->homography.inliers.size() / 2));
}

TEST(ImageRegistration, FailsWithoutReferenceAndOnBlankImages) {
  ImageRegistration registration{RegistrationOptions{}};
  EXPECT_FALSE(registration.hasReference());
  EXPECT_EQ(registration.registerImage(test_support::makeTexture(64, 48, 1)).status().code(),
            StatusCode::kInvalidInput);
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(registration.setReference(blank).code(), StatusCode::kTooFewPoints);
  ASSERT_TRUE(registration.setReference(test_support::makeTexture(640, 480, 4)).isOk());
  EXPECT_EQ(registration.registerImage(blank).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(registration.registerImage(cv::Mat()).status().code(), StatusCode::kInvalidInput);
}

// Real photographs: Debian's opencv-doc graffiti wall, graf1 -> graf3 (~40° viewpoint change).
TEST(ImageRegistration, RealGraffitiWallFromOpenCvDoc) {
  const std::string dir = kOpenCvData;
  if (!test_support::fileExists(dir + "/graf1.png")) {
    GTEST_SKIP() << "opencv-doc is not installed (" << dir << "): scripts/test installs it";
  }
  const auto truth = readHomographyFile(dir + "/H1to3p.xml");
  ASSERT_TRUE(truth.isOk()) << truth.status().toString();
  const double error = registerAndCompare(cv::imread(dir + "/graf1.png", cv::IMREAD_GRAYSCALE),
                                          cv::imread(dir + "/graf3.png", cv::IMREAD_GRAYSCALE),
                                          *truth, FeatureType::kSift);
  EXPECT_LT(error, 1.0);
}

// Real photographs with independent ground truth from ../shared/realdata (HPatches churchill).
TEST(ImageRegistration, RealPosterWallFromSharedRealData) {
  const std::string dir = kRealData + "/planar_homography_gt/hpatches_v_churchill";
  if (!test_support::fileExists(dir + "/1.ppm")) {
    GTEST_SKIP() << "shared real data not found at " << dir;
  }
  const cv::Mat reference = cv::imread(dir + "/1.ppm", cv::IMREAD_GRAYSCALE);
  for (int k : {2, 3}) {
    const double error = registerAndCompare(
        reference, cv::imread(dir + "/" + std::to_string(k) + ".ppm", cv::IMREAD_GRAYSCALE),
        *readHomographyFile(dir + "/H_1_" + std::to_string(k)), FeatureType::kSift);
    EXPECT_LT(error, 2.0) << "pair 1->" << k;
  }
}
