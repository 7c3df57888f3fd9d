#include "homography_teach_repeat/sim/texture_ripmap.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

// A BGR8 texture of white noise smoothed by 0.7 texels (detail at every scale down to a texel).
cv::Mat noiseTexture(int cols, int rows) {
  cv::Mat noise(rows, cols, CV_32FC3);
  cv::RNG rng(static_cast<std::uint64_t>(cols * 1000 + rows));
  rng.fill(noise, cv::RNG::NORMAL, 128.0, 60.0);
  cv::GaussianBlur(noise, noise, cv::Size(), 0.7, 0.7, cv::BORDER_REFLECT);
  cv::Mat texture;
  noise.convertTo(texture, CV_8UC3);
  return texture;
}

// The bilinear surface through the tiled texture's texels blurred by (σ_u, σ_v) at (u, v): its
// texels weighted by the Gaussian of the variance plus the interpolation's 1/6 (the triangle and
// the Gaussian convolved; within 1 % of exact for σ >= 0.7), summed directly.
cv::Vec3f exactlyBlurredAt(const cv::Mat& texture, double u, double v, double sigma_u, double sigma_v) {
  const double su = std::sqrt(sigma_u * sigma_u + 1.0 / 6.0), sv = std::sqrt(sigma_v * sigma_v + 1.0 / 6.0);
  const int ru = static_cast<int>(std::ceil(4.0 * su)) + 1, rv = static_cast<int>(std::ceil(4.0 * sv)) + 1;
  cv::Vec3d sum(0.0, 0.0, 0.0);
  double total = 0.0;
  for (int k = static_cast<int>(std::floor(v)) - rv; k <= static_cast<int>(std::floor(v)) + rv; ++k) {
    const double wv = std::exp(-0.5 * (k - v) * (k - v) / (sv * sv));
    for (int l = static_cast<int>(std::floor(u)) - ru; l <= static_cast<int>(std::floor(u)) + ru; ++l) {
      const double w = wv * std::exp(-0.5 * (l - u) * (l - u) / (su * su));
      const cv::Vec3b& t = texture.at<cv::Vec3b>(((k % texture.rows) + texture.rows) % texture.rows,
                                                 ((l % texture.cols) + texture.cols) % texture.cols);
      for (int c = 0; c < 3; ++c) sum[c] += w * t[c];
      total += w;
    }
  }
  return cv::Vec3f(static_cast<float>(sum[0] / total), static_cast<float>(sum[1] / total), static_cast<float>(sum[2] / total));
}

// RMS over a grid of off-texel points of (`sampled` − the exact blur by (σ_u, σ_v)) and the exact
// blur's standard deviation about its mean (grey levels, all channels).
template <typename Sampler>
std::pair<double, double> errorAndSignal(Sampler sampled, const cv::Mat& texture, double sigma_u, double sigma_v) {
  double error = 0.0, signal = 0.0, mean = 0.0;
  int n = 0;
  for (double v = -3.3; v < texture.rows; v += 5.7) {
    for (double u = -2.6; u < texture.cols; u += 4.9) {
      const cv::Vec3f got = sampled(u, v), want = exactlyBlurredAt(texture, u, v, sigma_u, sigma_v);
      for (int c = 0; c < 3; ++c) {
        error += (got[c] - want[c]) * (got[c] - want[c]);
        signal += want[c] * want[c];
        mean += want[c];
        ++n;
      }
    }
  }
  mean /= n;
  return {std::sqrt(error / n), std::sqrt(signal / n - mean * mean)};
}

}  // namespace

// With no blur asked for, a sample is the texture's own bilinear sample.
TEST(TextureRipmap, NoFootprintIsTheTexturesBilinearSample) {
  const cv::Mat texture = noiseTexture(120, 90);
  const TextureRipmap ripmap(texture);
  for (const auto& [u, v] : {std::pair{10.25, 20.5}, std::pair{0.0, 0.0}, std::pair{119.6, 89.3}}) {
    const cv::Vec3f got = ripmap.sample(u, v, 0.0, 0.0), want = sampleTiled(texture, u, v);
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(got[c], want[c]);
  }
}

// A sample is the texture blurred by the footprint's Gaussian, along each axis on its own (σ from
// 0.7 to 6 texels, round and 4:1 either way, across the seams of the tiling): within 12 % of the
// blurred texture's own variation (plus the levels' 8-bit rounding), and more than 2.5 times closer
// than the Gaussian of half or twice the σ. Measured when written: 5-10 % (half an octave between
// levels; an octave apart, 7-18 %), half or twice the σ 3.2-16 times further off.
TEST(TextureRipmap, ASampleIsTheTextureBlurredByTheFootprint) {
  const cv::Mat texture = noiseTexture(200, 160);
  const TextureRipmap ripmap(texture);
  for (const auto& [su, sv] : {std::pair{0.7, 0.7}, std::pair{1.5, 1.5}, std::pair{3.0, 3.0}, std::pair{6.0, 6.0},
                               std::pair{4.0, 1.0}, std::pair{1.0, 4.0}, std::pair{2.5, 0.0}}) {
    const auto [error, signal] = errorAndSignal([&](double u, double v) { return ripmap.sample(u, v, su, sv); }, texture, su, sv);
    EXPECT_LT(error, 0.12 * signal + 0.3) << "sigma " << su << ", " << sv << ": rms error " << error << " of " << signal;
    for (const double wrong : {0.5, 2.0}) {
      const auto [wrong_error, ignored] = errorAndSignal(
          [&](double u, double v) { return exactlyBlurredAt(texture, u, v, wrong * su, wrong * sv); }, texture, su, sv);
      EXPECT_GT(wrong_error, 2.5 * error) << "sigma " << su << ", " << sv << " against " << wrong << " times it";
    }
  }
}

// Tiled as the renderer tiles a wall's texture: a whole texture width or height further is the same.
TEST(TextureRipmap, SamplesAreTiled) {
  const cv::Mat texture = noiseTexture(100, 70);
  const TextureRipmap ripmap(texture);
  for (const double sigma : {0.0, 0.8, 3.0, 9.0}) {
    const cv::Vec3f here = ripmap.sample(12.3, 45.6, sigma, sigma);
    const cv::Vec3f there = ripmap.sample(12.3 + 100.0, 45.6 - 70.0, sigma, sigma);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(here[c], there[c], 1e-3) << "sigma " << sigma;
  }
}

// Any blur keeps a uniform texture uniform (the levels' weights sum to 1), beyond the coarsest too.
TEST(TextureRipmap, AUniformTextureStaysUniform) {
  const TextureRipmap ripmap(cv::Mat(64, 48, CV_8UC3, cv::Scalar(10, 100, 200)));
  for (const double sigma : {0.0, 0.3, 1.7, 6.0, 1000.0}) {
    const cv::Vec3f got = ripmap.sample(5.5, 7.25, sigma, 0.5 * sigma);
    EXPECT_NEAR(got[0], 10.0, 0.01);
    EXPECT_NEAR(got[1], 100.0, 0.01);
    EXPECT_NEAR(got[2], 200.0, 0.01);
  }
}

TEST(TextureRipmap, AnEmptyOrGreyTextureIsRefused) {
  EXPECT_THROW(TextureRipmap{cv::Mat()}, std::invalid_argument);
  EXPECT_THROW(TextureRipmap{cv::Mat(10, 10, CV_8UC1, cv::Scalar(0))}, std::invalid_argument);
}

// The cache builds a texture's ripmap once and tells textures apart by their pixels.
TEST(TextureRipmapCache, OneRipmapPerTexture) {
  TextureRipmapCache cache;
  const cv::Mat a = noiseTexture(40, 30), b = noiseTexture(40, 30);
  const TextureRipmap& first = cache.of(a);
  EXPECT_EQ(&first, &cache.of(a));
  EXPECT_NE(&first, &cache.of(b));
  EXPECT_EQ(cache.of(b).texture().data, b.data);
}

}  // namespace homography_teach_repeat
