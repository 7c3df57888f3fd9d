#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>

#include "homography_teach_repeat/eval/heading_pairs.h"

using namespace homography_teach_repeat;
namespace fs = std::filesystem;

class HeadingPairsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("htr_heading_pairs_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "site" / "images");
    fs::create_directories(dir_ / "site" / "ground_truth");
  }
  void TearDown() override { fs::remove_all(dir_); }

  void image(const fs::path& path) const { cv::imwrite(path.string(), cv::Mat(8, 16, CV_8UC1, cv::Scalar(100))); }
  void text(const fs::path& path, const std::string& content) const { std::ofstream(path) << content; }
  // Place 2 seen on visits 1, 2 and 3; its table 3 x 3.
  void griefSite() const {
    for (const char* name : {"0102.png", "0202.png", "0302.png"}) image(dir_ / "site" / "images" / name);
    text(dir_ / "site" / "ground_truth" / "location_2.txt", "0 12 -30\n-12 0 -42\n30 42 0\n");
  }
  static std::string errorOf(const std::string& path) {
    const auto pairs = eval::readHeadingPairs(path);
    EXPECT_FALSE(pairs.isOk());
    EXPECT_EQ(pairs.status().code(), StatusCode::kInvalidInput);
    return pairs.status().message();
  }

  fs::path dir_;
};

TEST_F(HeadingPairsTest, GriefSiteGivesEveryPairOfVisitsWithItsShift) {
  griefSite();
  const auto pairs = eval::readHeadingPairs((dir_ / "site").string());
  ASSERT_TRUE(pairs.isOk()) << pairs.status().toString();
  ASSERT_EQ(pairs->size(), 3u);  // 1-2, 1-3, 2-3
  std::map<std::string, double> shift;
  for (const auto& p : *pairs) {
    EXPECT_EQ(p.place, "2");
    shift[fs::path(p.reference_image).filename().string() + ">" + fs::path(p.current_image).filename().string()] =
        p.true_shift_px;
  }
  EXPECT_EQ(shift.at("0102.png>0202.png"), 12.0);
  EXPECT_EQ(shift.at("0102.png>0302.png"), -30.0);
  EXPECT_EQ(shift.at("0202.png>0302.png"), -42.0);
}

TEST_F(HeadingPairsTest, GriefSiteProblemsAreNamed) {
  EXPECT_NE(errorOf((dir_ / "site").string()).find("no images/MMLL.png"), std::string::npos);  // empty folder
  image(dir_ / "site" / "images" / "0101.png");
  image(dir_ / "site" / "images" / "0201.png");
  EXPECT_NE(errorOf((dir_ / "site").string()).find("location_1.txt"), std::string::npos);
  text(dir_ / "site" / "ground_truth" / "location_1.txt", "0 4\nx 0\n");
  EXPECT_NE(errorOf((dir_ / "site").string()).find("line 2: 'x' is not a number"), std::string::npos);
  image(dir_ / "site" / "images" / "0301.png");
  text(dir_ / "site" / "ground_truth" / "location_1.txt", "0 4\n-4 0\n");
  EXPECT_NE(errorOf((dir_ / "site").string()).find("no entry for visits 1 and 3"), std::string::npos);
  EXPECT_NE(errorOf((dir_ / "nothing").string()).find("neither"), std::string::npos);
}

TEST_F(HeadingPairsTest, ListFileWithRelativeAndAbsolutePaths) {
  image(dir_ / "a.png");
  image(dir_ / "b.png");
  text(dir_ / "pairs.txt", "# reference current shift\n\na.png " + (dir_ / "b.png").string() + " -17.5\n");
  const auto pairs = eval::readHeadingPairs((dir_ / "pairs.txt").string());
  ASSERT_TRUE(pairs.isOk()) << pairs.status().toString();
  ASSERT_EQ(pairs->size(), 1u);
  EXPECT_EQ(pairs->front().reference_image, (dir_ / "a.png").string());
  EXPECT_EQ(pairs->front().true_shift_px, -17.5);
  EXPECT_EQ(pairs->front().place, "3");
}

TEST_F(HeadingPairsTest, ListFileProblemsNameTheLine) {
  image(dir_ / "a.png");
  text(dir_ / "pairs.txt", "a.png missing.png 3\n");
  EXPECT_NE(errorOf((dir_ / "pairs.txt").string()).find("line 1: no image"), std::string::npos);
  text(dir_ / "pairs.txt", "a.png a.png\n");
  EXPECT_NE(errorOf((dir_ / "pairs.txt").string()).find("got 2 fields"), std::string::npos);
  text(dir_ / "pairs.txt", "\na.png a.png 3px\n");
  EXPECT_NE(errorOf((dir_ / "pairs.txt").string()).find("line 2: the shift '3px' is not a number"), std::string::npos);
  text(dir_ / "pairs.txt", "# nothing\n");
  EXPECT_NE(errorOf((dir_ / "pairs.txt").string()).find("lists no pair"), std::string::npos);
}

TEST(HeadingPairScore, FailsBeyondTheToleranceOrWithoutAnEstimate) {
  EXPECT_FALSE(eval::headingPairFailed(10.0, -20.0));
  EXPECT_FALSE(eval::headingPairFailed(15.0, -20.0));
  EXPECT_TRUE(eval::headingPairFailed(15.1, -20.0));
  EXPECT_TRUE(eval::headingPairFailed(std::nullopt, 0.0));
  EXPECT_TRUE(eval::headingPairFailed(std::nan(""), 0.0));
  EXPECT_FALSE(eval::headingPairFailed(-60.0, -20.0, 50.0));
}
