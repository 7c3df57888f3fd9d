// A wall texture prefiltered for any footprint: what a band-limited camera sees of it.
//
// A pixel of a real camera sees the scene through the lens's blur and integrates it over its
// area; a wall texture seen from far has more detail than the pixels, and one sample of it per
// pixel aliases (docs/simulator.md, "What a pixel sees"). The ripmap holds the texture blurred by
// Gaussians of σ = 0, 0.5, 0.71, 1, 1.41, ... texels (half an octave apart) along its rows and,
// independently, down its columns, each level resampled at one sample per σ (what folds back to
// low frequencies is then negligible); about 40 times the texture's bytes. sample() returns the
// texture blurred by (σ_u, σ_v) at a point: bilinear in each of the 2 x 2 levels around the
// footprint, blended so that the variances add up to the footprint's. Tiled in both directions, as
// the renderer tiles a wall's texture.
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <memory>
#include <mutex>
#include <vector>

namespace homography_teach_repeat {

class TextureRipmap {
 public:
  // `texture`: BGR8, not empty. Throws std::invalid_argument otherwise.
  explicit TextureRipmap(const cv::Mat& texture);

  // The texture blurred by a Gaussian of σ_u texels along its rows and σ_v down its columns, at
  // (u, v) in texel-index coordinates (texel (0, 0)'s centre at (0, 0)), tiled. σ beyond the
  // coarsest level gets that level's.
  cv::Vec3f sample(double u, double v, double sigma_u, double sigma_v) const;

  // The texture it was built from (kept alive: the renderer's cache is keyed by its pixels).
  const cv::Mat& texture() const { return texture_; }
  std::size_t levelsAlongRows() const { return sigmas_u_.size(); }
  std::size_t levelsDownColumns() const { return sigmas_v_.size(); }

 private:
  struct Level {
    cv::Mat image;  // BGR8
    double scale_u = 1.0, scale_v = 1.0;  // level texels per texture texel
  };
  cv::Mat texture_;
  std::vector<double> sigmas_u_, sigmas_v_;  // [texels of the texture], increasing from 0
  std::vector<Level> levels_;                // level (i, j) at j * sigmas_u_.size() + i

  const Level& level(std::size_t i, std::size_t j) const { return levels_[j * sigmas_u_.size() + i]; }
};

// The ripmaps of the textures a renderer has met, each built once (thread-safe).
class TextureRipmapCache {
 public:
  const TextureRipmap& of(const cv::Mat& texture);

 private:
  std::mutex mutex_;
  std::map<const unsigned char*, std::unique_ptr<const TextureRipmap>> entries_;
};

// Bilinear sample of a BGR8 texture tiled in both directions, at (u, v) in texel-index coordinates.
cv::Vec3f sampleTiled(const cv::Mat& texture, double u, double v);

}  // namespace homography_teach_repeat
