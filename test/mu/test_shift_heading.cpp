#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>

#include "homography_teach_repeat/mu/shift_heading.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

namespace {

// A 640 x 480 view of a textured scene, the camera turned so the scene moves `shift` px to the
// right, the light changed by `gain` and `offset`.
cv::Mat view(const cv::Mat& scene, int shift, double gain = 1.0, double offset = 0.0) {
  return test_support::turnedView(scene, 100, shift, gain, offset);
}

}  // namespace

TEST(ShiftHeading, MeasuresTheShiftOfATurnedViewUnderOtherLight) {
  const cv::Mat scene = test_support::makeTexture(840, 480, 31);
  ShiftHeading heading;
  const auto reference = heading.describe(view(scene, 0));
  ASSERT_TRUE(reference.isOk()) << reference.status().toString();
  ASSERT_EQ(reference->sets.size(), 2u);  // upright AKAZE and BRIEF
  for (const int shift : {-60, -7, 0, 25, 90}) {
    const auto current = heading.describe(view(scene, shift, 0.7, 25.0));
    ASSERT_TRUE(current.isOk());
    const auto fix = heading.measure(*reference, *current, 320.0);
    ASSERT_TRUE(fix.isOk()) << fix.status().toString();
    EXPECT_NEAR(fix->mu, shift, 1.0) << "shift " << shift;
    EXPECT_GT(fix->shift.support, 50);
    EXPECT_FALSE(fix->ambiguous);
    EXPECT_GE(fix->variance, heading.options().min_variance_px2);
    EXPECT_LT(fix->variance, heading.options().min_variance_px2 + 1.0);
  }
}

// Two halves of the view moved differently (a near object's parallax, repeated structure): the
// fix names the competition.
TEST(ShiftHeading, TwoCompetingShiftsMakeTheFixAmbiguous) {
  const cv::Mat scene = test_support::makeTexture(840, 480, 35);
  ShiftHeadingOptions options;
  options.vote.max_scale_change = 0.0;  // (halves moved apart are also a view scaled about its centre)
  ShiftHeading heading(options);
  const auto reference = heading.describe(view(scene, 0));
  cv::Mat current = view(scene, 40);
  view(scene, -40)(cv::Rect(320, 0, 320, 480)).copyTo(current(cv::Rect(320, 0, 320, 480)));
  const auto fix = heading.measure(*reference, *heading.describe(current), 320.0);
  ASSERT_TRUE(fix.isOk()) << fix.status().toString();
  EXPECT_TRUE(fix->ambiguous) << fix->shift.support << " against " << fix->shift.runner_up_support;
  EXPECT_NEAR(std::abs(fix->mu), 40.0, 2.0);
  EXPECT_NEAR(fix->shift.runner_up_shift_px, -fix->mu, 3.0);
  // A prediction near the winner picks it; one near the runner-up, halfway or unknown does not.
  EXPECT_TRUE(fix->pickedBy(fix->mu + 5.0));
  EXPECT_FALSE(fix->pickedBy(fix->shift.runner_up_shift_px));
  EXPECT_FALSE(fix->pickedBy(0.0));
  EXPECT_FALSE(fix->pickedBy(NAN));
  ShiftHeadingFix clear = *fix;
  clear.ambiguous = false;
  EXPECT_TRUE(clear.pickedBy(fix->shift.runner_up_shift_px));  // nothing competes: any prediction
}

// Two views of different places: their random matches agree only as much as chance makes them
// (14 of 199 in the fullest window): no fix (ImageShiftOptions::max_chance_probability).
TEST(ShiftHeading, UnrelatedViewsGiveNoFix) {
  ShiftHeading heading;
  for (const unsigned seed : {32U, 77U}) {
    const auto a = heading.describe(test_support::makeTexture(640, 480, seed));
    const auto b = heading.describe(test_support::makeTexture(640, 480, seed + 1));
    ASSERT_TRUE(a.isOk() && b.isOk());
    const auto fix = heading.measure(*a, *b, 320.0);
    ASSERT_FALSE(fix.isOk()) << seed << ": " << fix->mu << " px, support " << fix->shift.support;
    EXPECT_EQ(fix.status().code(), StatusCode::kNoConsensus);
    EXPECT_NE(fix.status().message().find("chance"), std::string::npos) << fix.status().message();
  }
}

TEST(ShiftHeading, BadInputIsAStatus) {
  ShiftHeading heading;
  const cv::Mat scene = test_support::makeTexture(840, 480, 34);
  const auto a = heading.describe(view(scene, 0));
  ASSERT_TRUE(a.isOk());
  cv::Mat small;
  cv::resize(view(scene, 0), small, cv::Size(320, 240));
  const auto b = heading.describe(small);
  ASSERT_TRUE(b.isOk());
  EXPECT_EQ(heading.measure(*a, *b, 320.0).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(heading.measure(*a, *a, std::nan("")).status().code(), StatusCode::kInvalidInput);
  ShiftFeatures fewer = *a;
  fewer.sets.pop_back();
  EXPECT_EQ(heading.measure(*a, fewer, 320.0).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(heading.describe(cv::Mat()).status().code(), StatusCode::kInvalidInput);
  const auto blank = heading.describe(cv::Mat(480, 640, CV_8UC1, cv::Scalar(80)));
  ASSERT_TRUE(blank.isOk());
  EXPECT_EQ(heading.measure(*blank, *blank, 320.0).status().code(), StatusCode::kTooFewPoints);
  ShiftHeadingOptions options;
  options.features.clear();
  EXPECT_THROW(ShiftHeading{options}, std::invalid_argument);
  options = ShiftHeadingOptions();
  options.min_variance_px2 = 0.0;
  EXPECT_THROW(ShiftHeading{options}, std::invalid_argument);
  options = ShiftHeadingOptions();
  options.ambiguity_ratio = 0.0;
  EXPECT_THROW(ShiftHeading{options}, std::invalid_argument);
}
