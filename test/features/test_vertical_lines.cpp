#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "homography_teach_repeat/features/vertical_lines.h"

using namespace homography_teach_repeat;

namespace {

// Vertical bands with edges at known sub-pixel x (anti-aliased by area coverage), slight blur.
cv::Mat bands(const std::vector<double>& edges, const std::vector<int>& greys, int width = 640,
              int height = 480, int top = 40, int bottom = 440) {
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(greys.front()));
  for (int y = top; y < bottom; ++y) {
    for (int x = 0; x < width; ++x) {
      // Grey of the band containing the pixel [x − 0.5, x + 0.5], area weighted.
      double value = 0.0;
      for (int s = 0; s < 16; ++s) {
        const double sx = x - 0.5 + (s + 0.5) / 16.0;
        std::size_t band = 0;
        while (band < edges.size() && sx > edges[band]) ++band;
        value += greys[band];
      }
      image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(value / 16.0);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.7);
  return image;
}

PinholeCamera camera(const std::string& model = "none", std::vector<double> d = {}) {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 500.0;
  c.cx = 320.0;
  c.cy = 240.0;
  c.distortion_model = model;
  c.distortion = std::move(d);
  return PinholeCamera(c);
}

}  // namespace

TEST(VerticalLines, SubPixelPositionPolarityAndBrightness) {
  const std::vector<double> edges{100.3, 250.7, 400.5};
  const cv::Mat image = bands(edges, {40, 200, 90, 170});
  VerticalLineExtractor extractor;
  const auto lines = extractor.extract(image);
  ASSERT_TRUE(lines.isOk()) << lines.status().toString();
  ASSERT_EQ(lines->size(), 3u);
  std::vector<VerticalLine> sorted = *lines;
  std::sort(sorted.begin(), sorted.end(), [](auto& a, auto& b) { return a.x < b.x; });
  const EdgePolarity expected[] = {EdgePolarity::kDarkLeft, EdgePolarity::kDarkRight,
                                   EdgePolarity::kDarkLeft};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(sorted[i].x, edges[i], 0.1) << i;
    EXPECT_EQ(sorted[i].polarity, expected[i]) << i;
    EXPECT_NEAR(sorted[i].length, 398.0, 4.0);
  }
  EXPECT_NEAR(sorted[0].left_brightness, 40.0, 2.0);
  EXPECT_NEAR(sorted[0].right_brightness, 200.0, 2.0);
  EXPECT_NEAR(sorted[1].right_brightness, 90.0, 2.0);
}

// Edges tilted beyond the tolerance are not vertical lines; within it they are.
TEST(VerticalLines, AngularTolerance) {
  cv::Mat image(480, 640, CV_8UC1, cv::Scalar(60));
  auto tilted = [&](double x_top, double degrees) {
    const double dx = std::tan(degrees * M_PI / 180.0) * 400.0;
    std::vector<cv::Point> polygon{{int(x_top), 40}, {int(x_top + 60), 40},
                                   {int(x_top + 60 + dx), 440}, {int(x_top + dx), 440}};
    cv::fillConvexPoly(image, polygon, cv::Scalar(200), cv::LINE_AA);
  };
  tilted(100.0, 2.0);   // kept (tolerance 5°)
  tilted(400.0, 12.0);  // dropped
  VerticalLineExtractor extractor;
  const auto lines = extractor.extract(image);
  ASSERT_TRUE(lines.isOk());
  ASSERT_EQ(lines->size(), 2u);  // both edges of the 2° band
  for (const auto& l : *lines) EXPECT_LT(l.x, 200.0);
}

// Endpoints are undistorted before x is taken: under radial distortion the image of the vertical
// line x_u = 420 is curved, and x comes back as 420. Both lens models of the issue: the
// single-parameter radial model of paper 002 and ROS's plumb_bob.
class VerticalLinesDistortion : public ::testing::TestWithParam<std::pair<std::string, std::vector<double>>> {};

TEST_P(VerticalLinesDistortion, DistortionIsCorrected) {
  const PinholeCamera lens = camera(GetParam().first, GetParam().second);
  const double x_undistorted = 420.0;
  cv::Mat image(480, 640, CV_8UC1);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 640; ++x) {
      const cv::Point2d u = lens.undistortPixel({double(x), double(y)});
      image.at<uint8_t>(y, x) = u.x < x_undistorted ? 50 : 190;
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  VerticalLineExtractor extractor;
  const auto with_lens = extractor.extract(image, &lens);
  ASSERT_TRUE(with_lens.isOk());
  ASSERT_GE(with_lens->size(), 1u);
  // The curve's ends, which jump a whole pixel, may come out as short separate pieces.
  const VerticalLine longest = *std::max_element(
      with_lens->begin(), with_lens->end(), [](auto& a, auto& b) { return a.length < b.length; });
  EXPECT_NEAR(longest.x, x_undistorted, 0.3);
  EXPECT_GT(longest.length, 250.0);
  // In undistorted pixels the line is vertical at x_u along its whole length.
  EXPECT_NEAR(longest.top_undistorted.x(), x_undistorted, 0.3);
  EXPECT_NEAR(longest.bottom_undistorted.x(), x_undistorted, 0.3);
}

INSTANTIATE_TEST_SUITE_P(
    LensModels, VerticalLinesDistortion,
    ::testing::Values(std::make_pair(std::string("single_parameter_radial"), std::vector<double>{-0.08}),
                      std::make_pair(std::string("plumb_bob"),
                                     std::vector<double>{-0.08, 0.01, 0.0005, -0.0003, 0.0})));

// min_gradient_fraction: the threshold follows the image's contrast. Strong edges (60 grey) and weak
// ones (12 grey) of one view; the same view at a fifth of the contrast (dusk) keeps the strong
// edges, and a relative threshold keeps them where an absolute one of the same effect loses them.
TEST(VerticalLines, ARelativeThresholdFollowsTheImagesContrast) {
  const cv::Mat bright = bands({100.5, 200.5, 300.5, 400.5, 500.5}, {60, 120, 132, 192, 204, 144});
  cv::Mat dim;
  bright.convertTo(dim, -1, 0.2, 100.0);
  VerticalLineOptions absolute;
  absolute.min_gradient = 100.0;  // the strong edges' |gx| is about 4 x 60 = 240, the weak ones' 48
  VerticalLineOptions relative;
  relative.min_gradient = 4.0;
  relative.min_gradient_fraction = 20.0;  // a mostly flat image: mean |gx| about 2.4 bright, 0.5 dim
  const auto count = [](const VerticalLineOptions& options, const cv::Mat& image) {
    return VerticalLineExtractor(options).extract(image)->size();
  };
  EXPECT_EQ(count(absolute, bright), 3u);
  EXPECT_EQ(count(absolute, dim), 0u) << "a fifth of the contrast is below the absolute threshold";
  EXPECT_EQ(count(relative, bright), 3u);
  EXPECT_EQ(count(relative, dim), 3u) << "the relative threshold falls with the contrast";
  relative.min_gradient_fraction = -1.0;
  EXPECT_THROW(VerticalLineExtractor{relative}, std::invalid_argument);
}

// The shortest line kept scales with the image unless given in rows (min_length_px > 0): 5.2 % of
// the height, 25 rows of 480, 20 of KITTI 07's 376, 10 of 188. A 24-row edge is a line in a
// 376-row image, not in a 480-row one.
TEST(VerticalLines, TheShortestLineScalesWithTheImage) {
  const VerticalLineOptions defaults;
  EXPECT_EQ(defaults.minLengthFor(480), 25);
  EXPECT_EQ(defaults.minLengthFor(376), 20);
  EXPECT_EQ(defaults.minLengthFor(188), 10);
  EXPECT_EQ(defaults.minLengthFor(20), 3);  // never below 3 rows
  VerticalLineOptions rows = defaults;
  rows.min_length_px = 15;
  EXPECT_EQ(rows.minLengthFor(480), 15);
  EXPECT_EQ(rows.minLengthFor(188), 15);

  VerticalLineExtractor extractor;
  const auto tall = extractor.extract(bands({300.4}, {40, 200}, 640, 480, 200, 224));
  ASSERT_TRUE(tall.isOk()) << tall.status().toString();
  EXPECT_TRUE(tall->empty());
  VerticalLineOptions twenty_rows;
  twenty_rows.min_length_px = 20;
  const auto tall_twenty = VerticalLineExtractor(twenty_rows).extract(bands({300.4}, {40, 200}, 640, 480, 200, 224));
  ASSERT_TRUE(tall_twenty.isOk()) << tall_twenty.status().toString();
  EXPECT_EQ(tall_twenty->size(), 1u);  // the same edge, 20 rows asked
  const auto short_image = extractor.extract(bands({300.4}, {40, 200}, 640, 376, 150, 174));
  ASSERT_TRUE(short_image.isOk()) << short_image.status().toString();
  ASSERT_EQ(short_image->size(), 1u);
  EXPECT_NEAR(short_image->front().x, 300.4, 0.1);
}

TEST(VerticalLines, NoVerticalStructureGivesNoLines) {
  VerticalLineExtractor extractor;
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(128));
  EXPECT_TRUE(extractor.extract(blank)->empty());
  cv::Mat horizontal(480, 640, CV_8UC1, cv::Scalar(40));
  horizontal.rowRange(200, 480).setTo(200);
  EXPECT_TRUE(extractor.extract(horizontal)->empty());
}

TEST(VerticalLines, BadInput) {
  VerticalLineExtractor extractor;
  EXPECT_EQ(extractor.extract(cv::Mat()).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(extractor.extract(cv::Mat(480, 640, CV_32FC1, cv::Scalar(0))).status().code(),
            StatusCode::kInvalidInput);
  const PinholeCamera small = [] {
    CameraCalibration c;
    c.width = 320;
    c.height = 240;
    c.fx = c.fy = 250.0;
    c.cx = 160.0;
    c.cy = 120.0;
    return PinholeCamera(c);
  }();
  EXPECT_EQ(extractor.extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), &small).status().code(),
            StatusCode::kInvalidInput);
  VerticalLineOptions options;
  options.max_angle_deg = 0.0;
  EXPECT_THROW(VerticalLineExtractor{options}, std::invalid_argument);
  options = VerticalLineOptions{};
  options.min_length_px = 2;  // rows: 0 (a share of the height) or at least 3
  EXPECT_THROW(VerticalLineExtractor{options}, std::invalid_argument);
  options = VerticalLineOptions{};
  options.min_length_fraction = 0.0;
  EXPECT_THROW(VerticalLineExtractor{options}, std::invalid_argument);
  // Found by fuzz_vertical_lines: a threshold beyond any 8-bit Sobel response (it overflowed the
  // int threshold) is refused; a huge brightness offset samples nothing instead of overflowing.
  options = VerticalLineOptions{};
  options.min_gradient = 7.6e307;
  EXPECT_THROW(VerticalLineExtractor{options}, std::invalid_argument);
  options = VerticalLineOptions{};
  options.brightness_offset_px = std::numeric_limits<int>::max();
  VerticalLineExtractor far_samples(options);
  const auto far_lines = far_samples.extract(bands({300.0}, {40, 200}));
  ASSERT_TRUE(far_lines.isOk());
  ASSERT_EQ(far_lines->size(), 1u);
  EXPECT_EQ((*far_lines)[0].left_brightness, 0.0);
  // A colour image works like its grey version.
  cv::Mat colour;
  cv::cvtColor(bands({300.0}, {40, 200}), colour, cv::COLOR_GRAY2BGR);
  EXPECT_EQ(extractor.extract(colour)->size(), 1u);
}
