#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <fstream>
#include <random>

#include <Eigen/Geometry>

#include "homography_teach_repeat/homography/homography.h"

using namespace homography_teach_repeat;

namespace {

Eigen::Matrix3d groundTruth() {
  Eigen::Matrix3d H;
  H << 0.76, -0.30, 225.7, 0.33, 1.01, -77.0, 3.5e-4, -1.4e-5, 1.0;
  return H;
}

PointMatches exactMatches(const Eigen::Matrix3d& H, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 800.0), v(0.0, 640.0);
  PointMatches matches;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d p(u(rng), v(rng));
    matches.push_back({p, applyHomography(H, p)});
  }
  return matches;
}

// Both up to scale and sign.
double projectiveDistance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::Matrix3d an = a / a.norm(), bn = b / b.norm();
  return std::min((an - bn).norm(), (an + bn).norm());
}

}  // namespace

TEST(HartleyNormalization, CentroidZeroMeanDistanceSqrt2) {
  const std::vector<Eigen::Vector2d> points{{10, 20}, {400, 30}, {250, 300}, {60, 470}};
  const auto n = computeHartleyNormalization(points);
  ASSERT_TRUE(n.isOk());
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  double mean_distance = 0.0;
  for (const auto& p : points) {
    const Eigen::Vector2d q = (n->transform * p.homogeneous()).head<2>();
    centroid += q / 4.0;
    mean_distance += q.norm() / 4.0;
  }
  EXPECT_LT(centroid.norm(), 1e-12);
  EXPECT_NEAR(mean_distance, std::sqrt(2.0), 1e-12);
  EXPECT_EQ(computeHartleyNormalization({{1, 1}, {1, 1}}).status().code(), StatusCode::kDegenerate);
}

TEST(HomographyDlt, ExactFromFourMatches) {
  const auto H = estimateHomographyDlt(exactMatches(groundTruth(), 4, 1));
  ASSERT_TRUE(H.isOk()) << H.status().toString();
  EXPECT_LT(projectiveDistance(*H, groundTruth()), 1e-9);
  EXPECT_NEAR(H->norm(), 1.0, 1e-12);
}

TEST(HomographyDlt, ExactFromManyMatches) {
  const auto H = estimateHomographyDlt(exactMatches(groundTruth(), 200, 2));
  ASSERT_TRUE(H.isOk());
  EXPECT_LT(projectiveDistance(*H, groundTruth()), 1e-9);
}

TEST(HomographyDlt, NoisyMatchesGiveSubPixelTransfer) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.5);
  PointMatches matches = exactMatches(groundTruth(), 100, 3);
  for (auto& m : matches) m.current += Eigen::Vector2d(noise(rng), noise(rng));
  const auto H = estimateHomographyDlt(matches);
  ASSERT_TRUE(H.isOk());
  const auto grid = meanGridTransferDifference(*H, groundTruth(), 800, 640, 800, 640, 20);
  ASSERT_TRUE(grid.isOk());
  EXPECT_LT(*grid, 0.5);
}

TEST(HomographyDlt, FewerThanFourMatches) {
  const auto H = estimateHomographyDlt(exactMatches(groundTruth(), 3, 4));
  EXPECT_EQ(H.status().code(), StatusCode::kTooFewPoints);
}

TEST(HomographyDlt, CollinearPoints) {
  PointMatches matches;
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector2d p(10.0 * i, 5.0 * i + 3.0);
    matches.push_back({p, applyHomography(groundTruth(), p)});
  }
  EXPECT_EQ(estimateHomographyDlt(matches).status().code(), StatusCode::kDegenerate);
}

TEST(HomographyDlt, ThreeOfFourCollinear) {
  PointMatches matches;
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0, 0), Eigen::Vector2d(100, 100),
                                  Eigen::Vector2d(200, 200), Eigen::Vector2d(0, 300)}) {
    matches.push_back({p, applyHomography(groundTruth(), p)});
  }
  EXPECT_EQ(estimateHomographyDlt(matches).status().code(), StatusCode::kDegenerate);
}

TEST(HomographyDlt, NonFiniteInput) {
  PointMatches matches = exactMatches(groundTruth(), 10, 5);
  matches[3].current.x() = NAN;
  const auto H = estimateHomographyDlt(matches);
  EXPECT_EQ(H.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(H.status().message().find("match 3"), std::string::npos);
}

TEST(TransferError, ZeroForExactAndSymmetricCounterpart) {
  const Eigen::Matrix3d H = groundTruth();
  const PointMatch m = exactMatches(H, 1, 6)[0];
  EXPECT_NEAR(transferError(H, m), 0.0, 1e-9);
  EXPECT_NEAR(symmetricTransferErrorSquared(H, H.inverse(), m), 0.0, 1e-16);
  PointMatch shifted = m;
  shifted.current.x() += 3.0;
  EXPECT_NEAR(transferError(H, shifted), 3.0, 1e-9);
  EXPECT_NEAR(rmsTransferError(H, {m, shifted}), std::sqrt(4.5), 1e-9);
  EXPECT_EQ(rmsTransferError(H, {}), 0.0);
}

TEST(MeanGridTransferDifference, IdenticalIsZeroAndNoOverlapFails) {
  EXPECT_NEAR(*meanGridTransferDifference(groundTruth(), groundTruth(), 800, 640, 800, 640, 10), 0.0,
              1e-12);
  Eigen::Matrix3d far_away = Eigen::Matrix3d::Identity();
  far_away(0, 2) = 1e5;
  EXPECT_FALSE(meanGridTransferDifference(groundTruth(), far_away, 800, 640, 800, 640, 10).isOk());
}

namespace {
std::string writeTemporary(const std::string& name, const std::string& content) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << content;
  return path;
}
}  // namespace

TEST(ReadHomographyFile, PlainTextAndOpenCvStorage) {
  const auto plain = readHomographyFile(
      writeTemporary("h_plain.txt", "0.76 -0.30 225.7\n0.33 1.01 -77.0\n3.5e-4 -1.4e-5 1.0\n"));
  ASSERT_TRUE(plain.isOk()) << plain.status().toString();
  EXPECT_LT((*plain - groundTruth()).norm(), 1e-12);

  const std::string xml_path = ::testing::TempDir() + "h_storage.xml";
  {
    cv::FileStorage storage(xml_path, cv::FileStorage::WRITE);
    cv::Mat m(3, 3, CV_64F);
    for (int k = 0; k < 9; ++k) m.at<double>(k / 3, k % 3) = groundTruth()(k / 3, k % 3);
    storage << "H13" << m;
  }
  const auto xml = readHomographyFile(xml_path);
  ASSERT_TRUE(xml.isOk()) << xml.status().toString();
  EXPECT_LT((*xml - groundTruth()).norm(), 1e-12);
}

TEST(ReadHomographyFile, FailuresNameTheFile) {
  const auto missing = readHomographyFile("/nonexistent/H.txt");
  EXPECT_EQ(missing.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(missing.status().message().find("/nonexistent/H.txt"), std::string::npos);
  const auto short_file = readHomographyFile(writeTemporary("h_short.txt", "1 0 0\n0 1 0\n"));
  EXPECT_EQ(short_file.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(short_file.status().message().find("needs 9 numbers, found 6"), std::string::npos);
  EXPECT_EQ(readHomographyFile(writeTemporary("h_nan.txt", "1 0 0 0 1 0 0 0 nan")).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(readHomographyFile(writeTemporary("h_bad.xml", "not xml at all")).status().code(),
            StatusCode::kInvalidInput);
}
