#include "homography_teach_repeat/mu/line_landmarks.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace homography_teach_repeat {
namespace {

const LineCamera kLens{707.0, 600.0};
constexpr double kWidth = 1200.0;

// A vertical edge of the world: where it stands (x, z in the keyframe camera frame) and how it looks.
struct Edge {
  Eigen::Vector2d position;
  EdgePolarity polarity = EdgePolarity::kDarkLeft;
  double left = 0.0, right = 0.0;
};

// The lines a camera at `camera` (keyframe camera frame) sees of `edges`, x with Gaussian noise;
// `seen[i]` is the index of edge i's line or -1.
std::vector<VerticalLine> render(const std::vector<Edge>& edges, const PlanarPose& camera, double noise_px,
                                 std::mt19937& rng, std::vector<int>* seen = nullptr) {
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<VerticalLine> lines;
  if (seen) seen->assign(edges.size(), -1);
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const auto x = projectLineLandmark(camera, edges[i].position, kLens);
    if (!x || *x < 0.0 || *x >= kWidth) continue;
    VerticalLine line;
    line.x = *x + noise(rng);
    line.polarity = edges[i].polarity;
    line.left_brightness = edges[i].left;
    line.right_brightness = edges[i].right;
    if (seen) (*seen)[i] = static_cast<int>(lines.size());
    lines.push_back(line);
  }
  return lines;
}

std::vector<Edge> randomStreet(int count, std::mt19937& rng) {
  std::uniform_real_distribution<double> side(3.0, 12.0), depth(4.0, 45.0), grey(20.0, 230.0);
  std::bernoulli_distribution left(0.5);
  std::vector<Edge> edges;
  for (int i = 0; i < count; ++i) {
    Edge e;
    e.position = Eigen::Vector2d(left(rng) ? -side(rng) : side(rng), depth(rng));
    e.polarity = left(rng) ? EdgePolarity::kDarkLeft : EdgePolarity::kDarkRight;
    e.left = grey(rng);
    e.right = grey(rng);
    edges.push_back(e);
  }
  return edges;
}

// The keyframe's neighbours of a car driving forwards through a gentle curve.
const std::vector<PlanarPose> kNeighbours = {PlanarPose(-0.05, 2.0, 0.03), PlanarPose(0.02, -2.0, -0.02),
                                             PlanarPose(-0.15, 4.0, 0.07), PlanarPose(0.0, -4.0, -0.03)};

TEST(LineLandmarks, ProjectionOfAnEdgeAheadAndBehind) {
  const auto ahead = projectLineLandmark(PlanarPose(), Eigen::Vector2d(1.0, 10.0), kLens);
  ASSERT_TRUE(ahead.isOk());
  EXPECT_NEAR(*ahead, 600.0 + 70.7, 1e-9);
  // Seen from 2 m ahead and turned: X2 = R2(θ)ᵀ (X1 − C).
  const PlanarPose turned(0.0, 2.0, 0.1);
  const auto x = projectLineLandmark(turned, Eigen::Vector2d(1.0, 10.0), kLens);
  ASSERT_TRUE(x.isOk());
  const double c = std::cos(0.1), s = std::sin(0.1);
  const double local_x = c * 1.0 + s * 8.0, local_z = -s * 1.0 + c * 8.0;
  EXPECT_NEAR(*x, 600.0 + 707.0 * local_x / local_z, 1e-9);
  EXPECT_EQ(projectLineLandmark(PlanarPose(0.0, 12.0, 0.0), Eigen::Vector2d(1.0, 10.0), kLens).status().code(),
            StatusCode::kDegenerate);
}

TEST(LineLandmarks, EdgesOfAStreetAreTriangulatedWithinTheirCovariance) {
  std::mt19937 rng(7);
  const std::vector<Edge> edges = randomStreet(80, rng);
  std::vector<int> in_keyframe;
  const auto lines = render(edges, PlanarPose(), 0.3, rng, &in_keyframe);
  std::vector<std::vector<VerticalLine>> neighbour_lines;
  for (const PlanarPose& pose : kNeighbours) neighbour_lines.push_back(render(edges, pose, 0.3, rng));
  std::vector<LineView> views;
  for (std::size_t v = 0; v < kNeighbours.size(); ++v) views.push_back(LineView{kNeighbours[v], &neighbour_lines[v]});
  LineLandmarkOptions options;
  options.pixel_sigma_px = 0.3;
  const auto landmarks = triangulateLineLandmarks(lines, views, kLens, options);
  ASSERT_TRUE(landmarks.isOk()) << landmarks.status().toString();
  // Edges the keyframe and at least two neighbours see.
  int triangulable = 0;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    int views_seeing = in_keyframe[i] >= 0 ? 1 : 0;
    for (const PlanarPose& pose : kNeighbours) {
      const auto x = projectLineLandmark(pose, edges[i].position, kLens);
      if (x && *x >= 0.0 && *x < kWidth) ++views_seeing;
    }
    if (in_keyframe[i] >= 0 && views_seeing >= 3) ++triangulable;
  }
  ASSERT_GT(triangulable, 30);
  EXPECT_GE(static_cast<int>(landmarks->size()), triangulable * 7 / 10);
  int consistent = 0;
  for (const LineLandmark& landmark : *landmarks) {
    int edge = -1;
    for (std::size_t i = 0; i < edges.size(); ++i) {
      if (in_keyframe[i] == landmark.line) edge = static_cast<int>(i);
    }
    ASSERT_GE(edge, 0);
    const Eigen::Vector2d error = landmark.position - edges[static_cast<std::size_t>(edge)].position;
    EXPECT_LT(error.norm(), 0.1 * edges[static_cast<std::size_t>(edge)].position.y()) << "edge " << edge;
    // χ² with 2 degrees of freedom, 99.9 %: 13.8.
    if (error.dot(landmark.covariance.inverse() * error) < 13.8) ++consistent;
    EXPECT_GE(landmark.views, 3);
  }
  EXPECT_GE(consistent, static_cast<int>(landmarks->size()) * 95 / 100);
}

TEST(LineLandmarks, ARowOfEqualEdgesGivesNoWrongLandmark) {
  // A fence along the street: equal posts every 1.5 m, 4 m to the left; the views move along it
  // by multiples of nearly the period, so a post pairs with its neighbour in some view.
  std::vector<Edge> edges;
  for (int i = 0; i < 30; ++i) edges.push_back(Edge{Eigen::Vector2d(-4.0, 3.0 + 1.5 * i), EdgePolarity::kDarkLeft, 60.0, 180.0});
  std::mt19937 rng(3);
  std::vector<int> in_keyframe;
  const auto lines = render(edges, PlanarPose(), 0.2, rng, &in_keyframe);
  const std::vector<PlanarPose> poses = {PlanarPose(0.0, 1.5, 0.0), PlanarPose(0.0, -1.5, 0.0), PlanarPose(0.0, 3.0, 0.0),
                                         PlanarPose(0.0, -3.0, 0.0)};
  std::vector<std::vector<VerticalLine>> neighbour_lines;
  for (const PlanarPose& pose : poses) neighbour_lines.push_back(render(edges, pose, 0.2, rng));
  std::vector<LineView> views;
  for (std::size_t v = 0; v < poses.size(); ++v) views.push_back(LineView{poses[v], &neighbour_lines[v]});
  const auto landmarks = triangulateLineLandmarks(lines, views, kLens);
  ASSERT_TRUE(landmarks.isOk());
  RecordProperty("landmarks", static_cast<int>(landmarks->size()));
  std::printf("fence: %zu of %zu posts triangulated\n", landmarks->size(), lines.size());
  for (const LineLandmark& landmark : *landmarks) {
    int edge = -1;
    for (std::size_t i = 0; i < edges.size(); ++i) {
      if (in_keyframe[i] == landmark.line) edge = static_cast<int>(i);
    }
    ASSERT_GE(edge, 0);
    EXPECT_LT((landmark.position - edges[static_cast<std::size_t>(edge)].position).norm(), 0.5)
        << "post " << edge << " placed at " << landmark.position.transpose();
  }
}

TEST(LineLandmarks, TwoViewsAreNotEnoughAndBadInputIsRefused) {
  std::mt19937 rng(1);
  const std::vector<Edge> edges = randomStreet(30, rng);
  const auto lines = render(edges, PlanarPose(), 0.3, rng);
  const auto other = render(edges, kNeighbours[0], 0.3, rng);
  // Two rays always meet: with one neighbour nothing can be checked, so nothing is claimed.
  const auto two = triangulateLineLandmarks(lines, {LineView{kNeighbours[0], &other}}, kLens);
  ASSERT_TRUE(two.isOk());
  EXPECT_TRUE(two->empty());
  EXPECT_EQ(triangulateLineLandmarks(lines, {LineView{kNeighbours[0], nullptr}}, kLens).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(triangulateLineLandmarks(lines, {LineView{PlanarPose(NAN, 0.0, 0.0), &other}}, kLens).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_FALSE(triangulateLineLandmarks(lines, {}, LineCamera{0.0, 600.0}).isOk());
  LineLandmarkOptions two_views;
  two_views.min_views = 2;
  EXPECT_THROW(two_views.validate(), std::invalid_argument);
  EXPECT_EQ(triangulateLineLandmarks(lines, {}, kLens, two_views).status().code(), StatusCode::kInvalidInput);
}

}  // namespace
}  // namespace homography_teach_repeat
