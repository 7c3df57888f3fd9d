#include "homography_teach_repeat/features/vertical_lines.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/features/feature_extractor.h"

namespace homography_teach_repeat {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

struct Chain {
  EdgePolarity polarity;
  int first_row = 0;
  int last_row = 0;
  double last_x = 0.0;
  int last_column = -1;
  double sum_abs_gradient = 0.0;
  std::vector<Eigen::Vector2f> points;  // (x, y)
};

}  // namespace

int VerticalLineOptions::minLengthFor(int image_rows) const {
  if (min_length_px > 0) return min_length_px;
  return std::max(3, static_cast<int>(std::lround(min_length_fraction * image_rows)));
}

void VerticalLineOptions::validate() const {
  if (!(max_angle_deg > 0.0 && max_angle_deg < 45.0)) {
    throw std::invalid_argument("vertical lines: max_angle_deg must be in (0, 45)");
  }
  if (min_length_px != 0 && min_length_px < 3) {
    throw std::invalid_argument("vertical lines: min_length_px must be 0 (a fraction of the image height) or >= 3");
  }
  if (!(min_length_fraction > 0.0 && min_length_fraction <= 1.0)) {
    throw std::invalid_argument("vertical lines: min_length_fraction must be in (0, 1]");
  }
  // 1020 = 4 · 255, the largest |gx| of the 3x3 Sobel on an 8-bit image: a higher threshold finds
  // nothing (and would not fit the int threshold; found by fuzz_vertical_lines).
  if (!(min_gradient > 0.0 && min_gradient <= 1020.0)) {
    throw std::invalid_argument("vertical lines: min_gradient must be in (0, 1020]");
  }
  if (!(min_gradient_fraction >= 0.0 && min_gradient_fraction <= 100.0)) {
    throw std::invalid_argument("vertical lines: min_gradient_fraction must be in [0, 100]");
  }
  if (!(max_step_px > 0.0)) throw std::invalid_argument("vertical lines: max_step_px must be > 0");
  if (max_row_gap < 0) throw std::invalid_argument("vertical lines: max_row_gap must be >= 0");
  if (!(max_fit_rms_px > 0.0)) {
    throw std::invalid_argument("vertical lines: max_fit_rms_px must be > 0");
  }
  if (brightness_offset_px < 1) {
    throw std::invalid_argument("vertical lines: brightness_offset_px must be >= 1");
  }
}

VerticalLineExtractor::VerticalLineExtractor(const VerticalLineOptions& options)
    : options_(options) {
  options_.validate();
}

Expected<std::vector<VerticalLine>> VerticalLineExtractor::extract(const cv::Mat& image,
                                                                   const PinholeCamera* camera) {
  auto gray = toGray8(image);
  if (!gray) return gray.status();
  gray_ = *gray;
  const int width = gray_.cols;
  const int height = gray_.rows;
  if (camera != nullptr && (camera->width() != width || camera->height() != height)) {
    return Status(StatusCode::kInvalidInput,
                  "image is " + std::to_string(width) + "x" + std::to_string(height) +
                      " but the calibration is for " + std::to_string(camera->width()) + "x" +
                      std::to_string(camera->height()));
  }
  std::vector<VerticalLine> lines;
  const int min_length = options_.minLengthFor(height);
  if (width < 3 || height < min_length) return lines;

  cv::Sobel(gray_, gx_, CV_16S, 1, 0, 3);
  cv::Sobel(gray_, gy_, CV_16S, 0, 1, 3);
  const double tan_tolerance = std::tan(options_.max_angle_deg * kDegToRad);
  // The image's own contrast: a share of its mean |gx| (min_gradient the floor).
  const double relative =
      options_.min_gradient_fraction > 0.0 ? options_.min_gradient_fraction * cv::mean(cv::abs(gx_))[0] : 0.0;
  const int threshold = static_cast<int>(std::ceil(std::max(options_.min_gradient, relative)));

  std::vector<Chain> chains;
  // Index of the chain whose last point is in column c (per polarity), or -1.
  std::vector<int> chain_at[2] = {std::vector<int>(width, -1), std::vector<int>(width, -1)};
  for (int y = 1; y < height - 1; ++y) {
    const int16_t* gx = gx_.ptr<int16_t>(y);
    const int16_t* gy = gy_.ptr<int16_t>(y);
    for (int x = 1; x < width - 1; ++x) {
      const int g = std::abs(static_cast<int>(gx[x]));
      if (g < threshold) continue;
      const int left = std::abs(static_cast<int>(gx[x - 1]));
      const int right = std::abs(static_cast<int>(gx[x + 1]));
      // Local maximum along x (ties: the left one wins) with a near-horizontal gradient.
      if (g < left || g <= right) continue;
      if (std::abs(static_cast<int>(gy[x])) > tan_tolerance * g) continue;
      const double denominator = left - 2.0 * g + right;
      const double offset = denominator < 0.0 ? 0.5 * (left - right) / denominator : 0.0;
      const double sub_x = x + offset;
      const EdgePolarity polarity = gx[x] > 0 ? EdgePolarity::kDarkLeft : EdgePolarity::kDarkRight;
      std::vector<int>& index = chain_at[polarity == EdgePolarity::kDarkLeft ? 0 : 1];
      int best = -1;
      double best_step = options_.max_step_px;
      for (int c = std::max(0, x - 1); c <= std::min(width - 1, x + 1); ++c) {
        const int id = index[c];
        if (id < 0) continue;
        const Chain& chain = chains[static_cast<std::size_t>(id)];
        if (chain.last_row >= y || chain.last_row < y - 1 - options_.max_row_gap) continue;
        const double step = std::abs(chain.last_x - sub_x);
        if (step <= best_step) {
          best_step = step;
          best = id;
        }
      }
      if (best < 0) {
        best = static_cast<int>(chains.size());
        Chain chain;
        chain.polarity = polarity;
        chain.first_row = y;
        chains.push_back(chain);
      } else {
        const int old_column = chains[static_cast<std::size_t>(best)].last_column;
        if (index[old_column] == best) index[old_column] = -1;
      }
      Chain& chain = chains[static_cast<std::size_t>(best)];
      chain.last_row = y;
      chain.last_x = sub_x;
      chain.last_column = x;
      chain.sum_abs_gradient += g;
      chain.points.emplace_back(static_cast<float>(sub_x), static_cast<float>(y));
      index[x] = best;
    }
  }

  const double cy = camera != nullptr ? camera->cy() : 0.5 * (height - 1);
  std::vector<Eigen::Vector2d> fit_points;
  for (const Chain& chain : chains) {
    const int rows = chain.last_row - chain.first_row + 1;
    if (rows < min_length || static_cast<int>(chain.points.size()) < min_length * 2 / 3) {
      continue;
    }
    // The straightness test and the line fit are done where lines are straight: in undistorted
    // pixels when a lens model is given (every other point is undistorted: a long line under
    // radial distortion is a curve in the image), and levelled when the mount is tilted (a wall's
    // vertical edge is vertical in the level camera only, docs/math.md §1.1).
    const bool undistort = camera != nullptr && !camera->isIdealPinhole();
    fit_points.clear();
    for (std::size_t i = 0; i < chain.points.size(); i += undistort ? 2 : 1) {
      const auto& p = chain.points[i];
      if (undistort) {
        const cv::Point2d u = camera->undistortPixel({p.x(), p.y()});
        if (std::isfinite(u.x) && std::isfinite(u.y)) fit_points.emplace_back(u.x, u.y);
      } else {
        fit_points.emplace_back(p.x(), p.y());
      }
    }
    if (fit_points.size() < 2) continue;
    // Least squares x = a + b (y − ȳ).
    double mean_x = 0.0, mean_y = 0.0;
    for (const auto& p : fit_points) {
      mean_x += p.x();
      mean_y += p.y();
    }
    const double n = static_cast<double>(fit_points.size());
    mean_x /= n;
    mean_y /= n;
    double syy = 0.0, sxy = 0.0;
    for (const auto& p : fit_points) {
      syy += (p.y() - mean_y) * (p.y() - mean_y);
      sxy += (p.y() - mean_y) * (p.x() - mean_x);
    }
    const double slope = syy > 0.0 ? sxy / syy : 0.0;
    if (std::abs(slope) > tan_tolerance) continue;
    double residual = 0.0;
    for (const auto& p : fit_points) {
      const double r = p.x() - (mean_x + slope * (p.y() - mean_y));
      residual += r * r;
    }
    if (std::sqrt(residual / n) > options_.max_fit_rms_px) continue;

    VerticalLine line;
    line.polarity = chain.polarity;
    line.top = chain.points.front().cast<double>();
    line.bottom = chain.points.back().cast<double>();
    line.length = (line.bottom - line.top).norm();
    line.contrast = chain.sum_abs_gradient / static_cast<double>(chain.points.size());
    const double y_top = fit_points.front().y();
    const double y_bottom = fit_points.back().y();
    line.top_undistorted = Eigen::Vector2d(mean_x + slope * (y_top - mean_y), y_top);
    line.bottom_undistorted = Eigen::Vector2d(mean_x + slope * (y_bottom - mean_y), y_bottom);
    line.x = mean_x + slope * (cy - mean_y);
    if (!std::isfinite(line.x)) continue;
    double left_sum = 0.0, right_sum = 0.0;
    int samples = 0;
    const int offset = options_.brightness_offset_px;
    for (std::size_t i = 0; i < chain.points.size(); i += 2) {
      const int px = static_cast<int>(std::lround(chain.points[i].x()));
      const int py = static_cast<int>(chain.points[i].y());
      if (offset > px || offset >= width - px) continue;  // (px ± offset could overflow)
      const uint8_t* row = gray_.ptr<uint8_t>(py);
      left_sum += row[px - offset];
      right_sum += row[px + offset];
      ++samples;
    }
    if (samples > 0) {
      line.left_brightness = left_sum / samples;
      line.right_brightness = right_sum / samples;
    }
    lines.push_back(line);
  }
  return lines;
}

}  // namespace homography_teach_repeat
