// LineShift (mu/line_shift.h): μ from vertical lines alone, matched by BRIEF along each line.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <stdexcept>

#include "homography_teach_repeat/mu/line_shift.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

namespace {

// A 900 x 480 scene of vertical structure: bars (posts, trunks, door frames) of random widths,
// heights, rows and grey levels over a textured background.
cv::Mat barScene(unsigned seed, int bars = 40) {
  cv::Mat scene = test_support::makeTexture(900, 480, seed);
  cv::GaussianBlur(scene, scene, cv::Size(0, 0), 2.0);  // the background's edges weaker than the bars'
  cv::RNG rng(seed);
  for (int i = 0; i < bars; ++i) {
    const int x = rng.uniform(10, 880), width = rng.uniform(3, 20);
    const int top = rng.uniform(0, 300), height = rng.uniform(60, 480 - top);
    cv::rectangle(scene, cv::Rect(x, top, width, height), cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
  }
  return scene;
}

// A 640 x 480 view, the camera turned so the scene moves `shift` px to the right, the light changed.
cv::Mat view(const cv::Mat& scene, int shift, double gain = 1.0, double offset = 0.0) {
  return test_support::turnedView(scene, 130, shift, gain, offset);
}

}  // namespace

TEST(LineShift, MeasuresTheShiftOfATurnedViewUnderOtherLight) {
  const cv::Mat scene = barScene(7);
  LineShift line_shift;
  const auto reference = line_shift.describe(view(scene, 0));
  ASSERT_TRUE(reference.isOk()) << reference.status().toString();
  EXPECT_GT(reference->lines.size(), 30u);
  for (const cv::KeyPoint& point : reference->points.keypoints) {
    ASSERT_GE(point.class_id, 0);
    EXPECT_FLOAT_EQ(point.pt.x, static_cast<float>(reference->lines[static_cast<std::size_t>(point.class_id)].x));
  }
  for (const int shift : {-80, -9, 0, 23, 110}) {
    const auto current = line_shift.describe(view(scene, shift, 0.6, 40.0));
    ASSERT_TRUE(current.isOk());
    const auto fix = line_shift.measure(*reference, *current, 320.0);
    ASSERT_TRUE(fix.isOk()) << "shift " << shift << ": " << fix.status().toString();
    EXPECT_NEAR(fix->mu, shift, 1.0) << "shift " << shift;
    EXPECT_GT(fix->shift.support, 30);
    EXPECT_FALSE(fix->ambiguous);
    EXPECT_GE(fix->variance, line_shift.options().min_variance_px2);
  }
}

// The lines of one season and the next: half the bars gone, new ones where there were none, and
// noise; the lines that stayed still agree.
TEST(LineShift, LinesThatStayedOutvoteLinesThatCameAndWent) {
  const cv::Mat before = barScene(11, 40);
  cv::Mat after = before.clone();
  cv::RNG rng(5);
  for (int i = 0; i < 20; ++i) {  // the new season's clutter
    const int x = rng.uniform(10, 880), top = rng.uniform(0, 300);
    cv::rectangle(after, cv::Rect(x, top, rng.uniform(3, 20), rng.uniform(60, 480 - top)), cv::Scalar(rng.uniform(0, 256)),
                  cv::FILLED);
  }
  cv::Mat noise(after.size(), CV_16S);
  cv::randn(noise, 0, 6);
  after.convertTo(after, CV_16S);
  after += noise;
  after.convertTo(after, CV_8U);
  LineShift line_shift;
  const auto reference = line_shift.describe(view(before, 0));
  const auto current = line_shift.describe(view(after, -37, 1.3, -20.0));
  ASSERT_TRUE(reference.isOk() && current.isOk());
  const auto fix = line_shift.measure(*reference, *current, 320.0);
  ASSERT_TRUE(fix.isOk()) << fix.status().toString();
  EXPECT_NEAR(fix->mu, -37.0, 1.5);
}

// Identical posts at a fixed spacing: every multiple of the spacing could be the shift. No fix, or
// one that says it is ambiguous; never one that claims to know.
TEST(LineShift, RepeatedPostsGiveNoUnquestionedFix) {
  cv::Mat scene(480, 900, CV_8UC1, cv::Scalar(170));
  for (int x = 5; x < 900; x += 60) cv::rectangle(scene, cv::Rect(x, 80, 8, 320), cv::Scalar(40), cv::FILLED);
  LineShift line_shift;
  const auto reference = line_shift.describe(view(scene, 0));
  const auto current = line_shift.describe(view(scene, 20));
  ASSERT_TRUE(reference.isOk() && current.isOk());
  const auto fix = line_shift.measure(*reference, *current, 320.0);
  if (!fix.isOk()) {
    EXPECT_TRUE(fix.status().code() == StatusCode::kNoConsensus || fix.status().code() == StatusCode::kTooFewPoints)
        << fix.status().toString();
  } else {
    EXPECT_TRUE(fix->ambiguous) << "mu " << fix->mu << ", support " << fix->shift.support << ", runner-up "
                                << fix->shift.runner_up_support;
  }
}

TEST(LineShift, WithoutLinesOrWithViewsOfDifferentSizesThereIsNoFix) {
  LineShift line_shift;
  const auto lines = line_shift.describe(view(barScene(3), 0));
  const auto blank = line_shift.describe(cv::Mat(480, 640, CV_8UC1, cv::Scalar(120)));
  ASSERT_TRUE(lines.isOk() && blank.isOk());
  EXPECT_TRUE(blank->lines.empty());
  const auto none = line_shift.measure(*lines, *blank, 320.0);
  ASSERT_FALSE(none.isOk());
  EXPECT_EQ(none.status().code(), StatusCode::kTooFewPoints);
  EXPECT_NE(none.status().message().find("current"), std::string::npos) << none.status().message();
  const auto small = line_shift.describe(cv::Mat(240, 320, CV_8UC1, cv::Scalar(120)));
  ASSERT_TRUE(small.isOk());
  const auto sizes = line_shift.measure(*lines, *small, 320.0);
  ASSERT_FALSE(sizes.isOk());
  EXPECT_EQ(sizes.status().code(), StatusCode::kInvalidInput);
  EXPECT_FALSE(line_shift.describe(cv::Mat()).isOk());
  EXPECT_FALSE(line_shift.describe(cv::Mat(480, 640, CV_32FC1, cv::Scalar(0.5))).isOk());
}

TEST(LineShift, BadOptionsAreRefusedNamingThem) {
  LineShiftOptions options;
  options.point_spacing_px = 0.5;
  EXPECT_THROW(LineShift{options}, std::invalid_argument);
  options = LineShiftOptions();
  options.min_length_fraction = 0.0;
  EXPECT_THROW(LineShift{options}, std::invalid_argument);
  options = LineShiftOptions();
  options.ambiguity_ratio = 1.5;
  EXPECT_THROW(LineShift{options}, std::invalid_argument);
}
