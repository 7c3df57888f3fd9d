#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "homography_teach_repeat/network/place_index.h"
#include "network/network_fixtures.h"
#include "homography_teach_repeat/eval/synthetic_places.h"

using namespace homography_teach_repeat;
using namespace homography_teach_repeat::synthetic_places;

namespace {

std::vector<cv::Mat> teach(const World& world, int places, cv::RNG& rng, double noise) {
  std::vector<cv::Mat> taught;
  for (int p = 0; p < places; ++p) taught.push_back(visit(world, p, 0.9, noise, rng));
  return taught;
}

// Of `queries` revisits with `fraction` of the landmarks, how many have their place (or a
// neighbour sharing most of the window) among the first `count` candidates.
int found(const PlaceIndex& index, const World& world, int places, double fraction, double noise, int count,
          cv::RNG& rng) {
  int hits = 0;
  for (int p = 0; p < places; ++p) {
    const auto candidates = index.query(visit(world, p, fraction, noise, rng), count);
    EXPECT_TRUE(candidates.isOk());
    for (const PlaceCandidate& c : *candidates) {
      if (std::abs(static_cast<int>(c.place) - p) <= 1) {
        ++hits;
        break;
      }
    }
  }
  return hits;
}

}  // namespace

TEST(PlaceIndex, FindsTheRevisitedPlaceWithFloatDescriptors) {
  const int places = 150;
  const World world = makeWorld(places, 200, 20, /*binary=*/false);
  cv::RNG rng(1);
  const auto index = PlaceIndex::build(teach(world, places, rng, 0.05));
  ASSERT_TRUE(index.isOk()) << index.status().toString();
  EXPECT_EQ(index->size(), static_cast<std::size_t>(places));
  EXPECT_EQ(index->words(), 256);
  EXPECT_EQ(index->dimensions(), 256);
  // Half of the landmarks seen again, with noise: the place is the best candidate nearly always
  // and among the first five always.
  EXPECT_GE(found(*index, world, places, 0.5, 0.05, 1, rng), places * 9 / 10);
  EXPECT_EQ(found(*index, world, places, 0.5, 0.05, 5, rng), places);
  const auto best = index->query(visit(world, 40, 0.9, 0.05, rng), 3);
  ASSERT_EQ(best->size(), 3u);
  EXPECT_GE((*best)[0].similarity, (*best)[1].similarity);
  EXPECT_LE((*best)[0].similarity, 1.0 + 1e-6);
}

TEST(PlaceIndex, FindsTheRevisitedPlaceWithBinaryDescriptors) {
  const int places = 120;
  const World world = makeWorld(places, 200, 20, /*binary=*/true);
  cv::RNG rng(2);
  const auto index = PlaceIndex::build(teach(world, places, rng, 8));
  ASSERT_TRUE(index.isOk()) << index.status().toString();
  EXPECT_GE(found(*index, world, places, 0.5, 8, 5, rng), places * 95 / 100);
}

TEST(PlaceIndex, AReducedVectorStillFindsThePlace) {
  const int places = 150;
  const World world = makeWorld(places, 200, 20, /*binary=*/false);
  cv::RNG rng(9);
  PlaceIndexOptions reduced;
  reduced.dimensions = 64;
  const auto index = PlaceIndex::build(teach(world, places, rng, 0.05), reduced);
  ASSERT_TRUE(index.isOk()) << index.status().toString();
  EXPECT_EQ(index->dimensions(), 64);
  EXPECT_GE(found(*index, world, places, 0.5, 0.05, 5, rng), places * 95 / 100);
}

TEST(PlaceIndex, ASmallMapWorksWithoutProjection) {
  const World world = makeWorld(5, 100, 50, false);
  cv::RNG rng(3);
  const auto index = PlaceIndex::build(teach(world, 5, rng, 0.05));
  ASSERT_TRUE(index.isOk()) << index.status().toString();
  EXPECT_EQ(index->dimensions(), index->words());
  const auto candidates = index->query(visit(world, 3, 0.7, 0.05, rng), 10);
  ASSERT_TRUE(candidates.isOk());
  EXPECT_EQ(candidates->size(), 5u);
  EXPECT_EQ(candidates->front().place, 3u);
}

TEST(PlaceIndex, KeyframesWithoutDescriptorsAreNeverProposed) {
  const World world = makeWorld(80, 200, 20, false);
  cv::RNG rng(4);
  std::vector<cv::Mat> taught = teach(world, 80, rng, 0.05);
  taught[10] = cv::Mat();
  taught[11] = cv::Mat(0, 128, CV_32F);
  const auto index = PlaceIndex::build(taught);
  ASSERT_TRUE(index.isOk());
  EXPECT_EQ(index->size(), 80u);
  const auto candidates = index->query(visit(world, 10, 0.9, 0.05, rng), 80);
  ASSERT_TRUE(candidates.isOk());
  EXPECT_EQ(candidates->size(), 78u);
  for (const auto& c : *candidates) EXPECT_TRUE(c.place != 10 && c.place != 11);
  EXPECT_TRUE(index->query(cv::Mat(), 5)->empty());
}

TEST(PlaceIndex, BadInputIsRefused) {
  EXPECT_EQ(PlaceIndex::build({}).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(PlaceIndex::build({cv::Mat(), cv::Mat()}).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(PlaceIndex::build({cv::Mat(1, 128, CV_32F, cv::Scalar(0.5))}).status().code(), StatusCode::kInvalidInput);
  cv::Mat floats(10, 128, CV_32F, cv::Scalar(0.5));
  cv::Mat bytes(10, 32, CV_8U, cv::Scalar(7));
  EXPECT_EQ(PlaceIndex::build({floats, bytes}).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(PlaceIndex::build({floats, cv::Mat(10, 64, CV_32F, cv::Scalar(0.1))}).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(PlaceIndex::build({cv::Mat(10, 128, CV_64F, cv::Scalar(0.5))}).status().code(), StatusCode::kInvalidInput);
  cv::Mat nan = floats.clone();
  nan.at<float>(3, 3) = std::nanf("");
  EXPECT_EQ(PlaceIndex::build({nan}).status().code(), StatusCode::kNotFinite);
  PlaceIndexOptions bad;
  bad.vocabulary_words = 1;
  EXPECT_EQ(PlaceIndex::build({floats}, bad).status().code(), StatusCode::kInvalidInput);
  const World world = makeWorld(30, 100, 20, false);
  cv::RNG rng(5);
  const auto index = PlaceIndex::build(teach(world, 30, rng, 0.05));
  ASSERT_TRUE(index.isOk());
  EXPECT_EQ(index->query(bytes, 3).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(index->query(nan, 3).status().code(), StatusCode::kNotFinite);
}

TEST(PlaceIndex, SavedAndLoadedItProposesTheSame) {
  const World world = makeWorld(100, 200, 20, false);
  cv::RNG rng(6);
  auto index = PlaceIndex::build(teach(world, 100, rng, 0.05));
  ASSERT_TRUE(index.isOk());
  const std::string dir = network_test::temporaryDirectory();
  const std::string path = dir + "/place_index.yml";
  PlaceIndex labelled = std::move(*index);
  EXPECT_EQ(labelled.setLabels({"only one"}).code(), StatusCode::kInvalidInput);
  std::vector<std::string> labels;
  for (int p = 0; p < 100; ++p) labels.push_back("route:" + std::to_string(p));
  ASSERT_TRUE(labelled.setLabels(labels).isOk());
  ASSERT_TRUE(labelled.save(path).isOk());
  const auto loaded = PlaceIndex::load(path);
  ASSERT_TRUE(loaded.isOk()) << loaded.status().toString();
  EXPECT_EQ(loaded->size(), labelled.size());
  EXPECT_EQ(loaded->labels(), labels);
  for (int p = 0; p < 100; p += 7) {
    const cv::Mat query = visit(world, p, 0.6, 0.05, rng);
    const auto a = labelled.query(query, 5);
    const auto b = loaded->query(query, 5);
    ASSERT_EQ(a->size(), b->size());
    for (std::size_t i = 0; i < a->size(); ++i) {
      EXPECT_EQ((*a)[i].place, (*b)[i].place);
      EXPECT_NEAR((*a)[i].similarity, (*b)[i].similarity, 1e-5);
    }
  }
  // Corrupt or missing files are refused naming the file.
  std::ofstream(dir + "/truncated.yml") << "%YAML:1.0\nformat_version: 1\nbinary: 0\n";
  const auto truncated = PlaceIndex::load(dir + "/truncated.yml");
  ASSERT_FALSE(truncated.isOk());
  EXPECT_NE(truncated.status().message().find("truncated.yml"), std::string::npos);
  std::ofstream(dir + "/garbage.yml") << "{{{ not yaml";
  EXPECT_FALSE(PlaceIndex::load(dir + "/garbage.yml").isOk());
  EXPECT_FALSE(PlaceIndex::load(dir + "/missing.yml").isOk());
}

TEST(PlaceIndex, TheSameKeyframesGiveTheSameIndex) {
  const World world = makeWorld(70, 200, 20, false);
  cv::RNG rng(8);
  const auto taught = teach(world, 70, rng, 0.05);
  const auto a = PlaceIndex::build(taught);
  cv::theRNG().state = 999;  // whatever the caller's RNG holds
  const auto b = PlaceIndex::build(taught);
  const cv::Mat query = visit(world, 33, 0.6, 0.05, rng);
  const auto qa = a->query(query, 4);
  const auto qb = b->query(query, 4);
  ASSERT_EQ(qa->size(), qb->size());
  for (std::size_t i = 0; i < qa->size(); ++i) EXPECT_EQ((*qa)[i].place, (*qb)[i].place);
}
