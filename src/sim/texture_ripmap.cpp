#include "homography_teach_repeat/sim/texture_ripmap.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace homography_teach_repeat {

// The integer cell is wrapped with integer arithmetic: fmod of a tiny negative coordinate plus the
// width rounds to the width itself, one past the last column (found by AddressSanitizer).
cv::Vec3f sampleTiled(const cv::Mat& texture, double u, double v) {
  const int w = texture.cols, h = texture.rows;
  const double fu = std::floor(u), fv = std::floor(v);
  const float a = static_cast<float>(u - fu), b = static_cast<float>(v - fv);
  const long iu = static_cast<long>(fu), iv = static_cast<long>(fv);
  int u0 = static_cast<int>(iu), u1 = u0 + 1, v0 = static_cast<int>(iv), v1 = v0 + 1;
  if (iu < 0 || iu >= w - 1) {  // (inside, no division: the renderer's hot path)
    u0 = static_cast<int>(((iu % w) + w) % w);
    u1 = (u0 + 1) % w;
  }
  if (iv < 0 || iv >= h - 1) {
    v0 = static_cast<int>(((iv % h) + h) % h);
    v1 = (v0 + 1) % h;
  }
  const cv::Vec3b& p00 = texture.at<cv::Vec3b>(v0, u0);
  const cv::Vec3b& p01 = texture.at<cv::Vec3b>(v0, u1);
  const cv::Vec3b& p10 = texture.at<cv::Vec3b>(v1, u0);
  const cv::Vec3b& p11 = texture.at<cv::Vec3b>(v1, u1);
  cv::Vec3f out;
  for (int c = 0; c < 3; ++c) {
    out[c] = (1 - a) * (1 - b) * static_cast<float>(p00[c]) + a * (1 - b) * static_cast<float>(p01[c]) +
             (1 - a) * b * static_cast<float>(p10[c]) + a * b * static_cast<float>(p11[c]);
  }
  return out;
}

namespace {

// Consecutive levels' σ differ by this factor: half an octave. A blend of two levels stands for
// the Gaussian between them; an octave apart (σ and 2σ) the sharper one's share leaks the detail a
// band-limited image has not (8 mm stripes from 3 m kept a grey-level deviation of 15-20).
constexpr double kLevelRatio = 1.4142135623730951;

// A level's samples are max(1, σ) texels of the texture apart: one per σ (what folds back below a
// quarter of the level's Nyquist frequency is attenuated by exp(-2π²·0.75²) < 2e-5).
int levelSize(int size, double sigma) { return std::max(1, static_cast<int>(std::lround(size / std::max(1.0, sigma)))); }

// σ of the levels along one axis of `size` texels: 0, 0.5, 0.71, 1, 1.41, ... while a level keeps
// at least 16 samples (the next level's blur, at most 7 samples either side, then wraps within it).
std::vector<double> levelSigmas(int size) {
  std::vector<double> sigmas{0.0};
  for (double sigma = 0.5; levelSize(size, sigma) >= 16; sigma *= kLevelRatio) sigmas.push_back(sigma);
  return sigmas;
}

// The variance a level's bilinear sample blurs the texture by [texels²]: its Gaussian's plus the
// interpolation's (a triangle one sample wide: 1/6 sample², samples max(1, σ) texels apart).
double effectiveVariance(double sigma) {
  const double step = std::max(1.0, sigma);
  return sigma * sigma + step * step / 6.0;
}

// `image` (CV_32FC3) blurred along x (axis 0) or y (axis 1) by σ > 0 samples, tiled.
cv::Mat blurTiled(const cv::Mat& image, double sigma, int axis) {
  const int radius = static_cast<int>(std::ceil(4.0 * sigma));
  const cv::Mat gaussian = cv::getGaussianKernel(2 * radius + 1, sigma, CV_32F);
  const cv::Mat one = cv::Mat::ones(1, 1, CV_32F);
  cv::Mat padded, blurred;
  if (axis == 0) {
    cv::copyMakeBorder(image, padded, 0, 0, radius, radius, cv::BORDER_WRAP);
    cv::sepFilter2D(padded, blurred, CV_32F, gaussian, one);
    return blurred.colRange(radius, radius + image.cols).clone();
  }
  cv::copyMakeBorder(image, padded, radius, radius, 0, 0, cv::BORDER_WRAP);
  cv::sepFilter2D(padded, blurred, CV_32F, one, gaussian);
  return blurred.rowRange(radius, radius + image.rows).clone();
}

// The level of σ `to` from the level of σ `from` (both in texture texels; `image` holds `from`'s
// samples, `scale` of them per texture texel) along `axis`, resampled to `size` samples.
cv::Mat nextLevel(const cv::Mat& image, double from, double to, double scale, int size, int axis) {
  const cv::Mat blurred = blurTiled(image, std::sqrt(to * to - from * from) * scale, axis);
  cv::Mat resized;
  const cv::Size target = axis == 0 ? cv::Size(size, image.rows) : cv::Size(image.cols, size);
  cv::resize(blurred, resized, target, 0.0, 0.0, cv::INTER_LINEAR);
  return resized;
}

// Where the levels of a Gaussian of σ `sigma` lie: level `index` and the next one, blended with
// `weight` on the next, so that the variances add up to its. The texture is the bilinear surface
// through its texels (as the renderer's one sample per pixel takes it): blurred by σ, that is its
// texels blurred by σ² plus the interpolation's 1/6.
void bracket(const std::vector<double>& sigmas, double sigma, std::size_t& index, double& weight) {
  const double variance = sigma * sigma + effectiveVariance(0.0);
  index = 0;
  weight = 0.0;
  while (index + 1 < sigmas.size() && effectiveVariance(sigmas[index + 1]) <= variance) ++index;
  if (index + 1 == sigmas.size()) return;
  const double low = effectiveVariance(sigmas[index]), high = effectiveVariance(sigmas[index + 1]);
  weight = std::clamp((variance - low) / (high - low), 0.0, 1.0);
}

}  // namespace

TextureRipmap::TextureRipmap(const cv::Mat& texture) : texture_(texture) {
  if (texture.empty() || texture.type() != CV_8UC3) {
    throw std::invalid_argument("TextureRipmap: the texture must be a non-empty BGR8 image");
  }
  sigmas_u_ = levelSigmas(texture.cols);
  sigmas_v_ = levelSigmas(texture.rows);
  levels_.resize(sigmas_u_.size() * sigmas_v_.size());
  // Built in floats, stored in bytes: each level from its neighbour towards (0, 0), one axis at a time.
  std::vector<cv::Mat> column;  // the levels (i, 0) in floats
  cv::Mat base;
  texture.convertTo(base, CV_32FC3);
  for (std::size_t i = 0; i < sigmas_u_.size(); ++i) {
    if (i == 0) {
      column.push_back(base);
    } else {
      const double scale = static_cast<double>(column.back().cols) / texture.cols;
      column.push_back(nextLevel(column.back(), sigmas_u_[i - 1], sigmas_u_[i], scale,
                                 levelSize(texture.cols, sigmas_u_[i]), 0));
    }
    cv::Mat current = column.back();
    for (std::size_t j = 0; j < sigmas_v_.size(); ++j) {
      if (j > 0) {
        const double scale = static_cast<double>(current.rows) / texture.rows;
        current = nextLevel(current, sigmas_v_[j - 1], sigmas_v_[j], scale, levelSize(texture.rows, sigmas_v_[j]), 1);
      }
      Level& stored = levels_[j * sigmas_u_.size() + i];
      current.convertTo(stored.image, CV_8UC3);
      stored.scale_u = static_cast<double>(current.cols) / texture.cols;
      stored.scale_v = static_cast<double>(current.rows) / texture.rows;
    }
  }
}

cv::Vec3f TextureRipmap::sample(double u, double v, double sigma_u, double sigma_v) const {
  std::size_t i = 0, j = 0;
  double wu = 0.0, wv = 0.0;
  bracket(sigmas_u_, sigma_u, i, wu);
  bracket(sigmas_v_, sigma_v, j, wv);
  cv::Vec3f out(0.0f, 0.0f, 0.0f);
  for (int di = 0; di < 2; ++di) {
    const double weight_u = di == 0 ? 1.0 - wu : wu;
    if (weight_u == 0.0) continue;
    for (int dj = 0; dj < 2; ++dj) {
      const double weight = weight_u * (dj == 0 ? 1.0 - wv : wv);
      if (weight == 0.0) continue;
      const Level& l = level(i + static_cast<std::size_t>(di), j + static_cast<std::size_t>(dj));
      out += static_cast<float>(weight) * sampleTiled(l.image, (u + 0.5) * l.scale_u - 0.5, (v + 0.5) * l.scale_v - 0.5);
    }
  }
  return out;
}

const TextureRipmap& TextureRipmapCache::of(const cv::Mat& texture) {
  const std::lock_guard<std::mutex> lock(mutex_);
  // Keyed by the pixels' address: the ripmap holds the texture, so the address is not reused
  // while the entry lives.
  auto found = entries_.find(texture.data);
  if (found == entries_.end()) found = entries_.emplace(texture.data, std::make_unique<const TextureRipmap>(texture)).first;
  return *found->second;
}

}  // namespace homography_teach_repeat
