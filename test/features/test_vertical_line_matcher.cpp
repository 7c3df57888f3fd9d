#include <gtest/gtest.h>

#include "homography_teach_repeat/features/vertical_line_matcher.h"

using namespace homography_teach_repeat;

namespace {

VerticalLine line(double x, EdgePolarity polarity, double left, double right, double length = 120.0,
                  double mid_y = 240.0) {
  VerticalLine l;
  l.x = x;
  l.top = Eigen::Vector2d(x, mid_y - length / 2);
  l.bottom = Eigen::Vector2d(x, mid_y + length / 2);
  l.length = length;
  l.polarity = polarity;
  l.left_brightness = left;
  l.right_brightness = right;
  return l;
}

std::vector<VerticalLine> scene(double shift) {
  return {line(80 + shift, EdgePolarity::kDarkLeft, 40, 160),
          line(150 + shift, EdgePolarity::kDarkRight, 200, 60, 200),
          line(260 + shift, EdgePolarity::kDarkLeft, 90, 210, 80, 300),
          line(400 + shift, EdgePolarity::kDarkRight, 180, 30),
          line(530 + shift, EdgePolarity::kDarkLeft, 20, 120, 150, 200)};
}

}  // namespace

TEST(VerticalLineMatcher, ShiftedSceneMatchesOneToOne) {
  const auto matches = matchVerticalLines(scene(0.0), scene(25.0));
  ASSERT_TRUE(matches.isOk());
  ASSERT_EQ(matches->size(), 5u);
  for (const auto& m : *matches) EXPECT_EQ(m.reference, m.current);
}

// The two polarities never match, however close in x and brightness.
TEST(VerticalLineMatcher, PolarityIsNeverCrossed) {
  std::vector<VerticalLine> reference{line(100, EdgePolarity::kDarkLeft, 50, 150)};
  std::vector<VerticalLine> current{line(101, EdgePolarity::kDarkRight, 50, 150)};
  const auto matches = matchVerticalLines(reference, current);
  ASSERT_TRUE(matches.isOk());
  EXPECT_TRUE(matches->empty());
}

TEST(VerticalLineMatcher, DisparityLimitAndDistance) {
  LineMatchOptions options;
  options.max_disparity_px = 50.0;
  EXPECT_TRUE(matchVerticalLines(scene(0.0), scene(80.0), options)->empty());
  // Very different brightness: no match.
  std::vector<VerticalLine> reference{line(100, EdgePolarity::kDarkLeft, 20, 80)};
  std::vector<VerticalLine> current{line(105, EdgePolarity::kDarkLeft, 120, 250)};
  EXPECT_TRUE(matchVerticalLines(reference, current)->empty());
}

// Two equally good candidates: ambiguous, so no match (ratio test); mutual check on.
TEST(VerticalLineMatcher, AmbiguousCandidatesAreDropped) {
  std::vector<VerticalLine> reference{line(100, EdgePolarity::kDarkLeft, 50, 150)};
  std::vector<VerticalLine> current{line(110, EdgePolarity::kDarkLeft, 50, 150),
                                    line(90, EdgePolarity::kDarkLeft, 50, 150)};
  EXPECT_TRUE(matchVerticalLines(reference, current)->empty());
}

TEST(VerticalLineMatcher, BadInput) {
  auto reference = scene(0.0);
  reference[2].x = std::nan("");
  EXPECT_EQ(matchVerticalLines(reference, scene(0.0)).status().code(), StatusCode::kInvalidInput);
  EXPECT_TRUE(matchVerticalLines({}, scene(0.0))->empty());
  LineMatchOptions options;
  options.ratio = 0.0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
}
