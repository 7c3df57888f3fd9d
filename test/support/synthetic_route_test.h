// A gtest fixture: the synthetic wall and a route taught along it once per test suite (AKAZE),
// removed at the end. For the tests of the repeat phase.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "support/synthetic_route.h"

namespace homography_teach_repeat {
namespace test_support {

class SyntheticRouteTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    wall_ = new SyntheticWall();
    directory_ = teachSyntheticRoute(*wall_, FeatureType::kAkaze);
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(directory_);
    delete wall_;
    wall_ = nullptr;
  }
  static Route route() {
    auto r = loadRoute(directory_);
    EXPECT_TRUE(r.isOk()) << r.status().toString();
    return *r;
  }
  inline static SyntheticWall* wall_ = nullptr;
  inline static std::string directory_;
};

}  // namespace test_support
}  // namespace homography_teach_repeat
