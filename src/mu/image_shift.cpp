#include "homography_teach_repeat/mu/image_shift.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

namespace homography_teach_repeat {

void ImageShiftOptions::validate() const {
  if (!(window_fraction > 0.0 && window_fraction < 1.0)) {
    throw std::invalid_argument("image shift window_fraction must be in (0, 1)");
  }
  if (!(vertical_limit_fraction > 0.0) || !std::isfinite(vertical_limit_fraction)) {
    throw std::invalid_argument("image shift vertical_limit_fraction must be > 0");
  }
  if (min_support < 1) throw std::invalid_argument("image shift min_support must be >= 1");
  if (!(max_scale_change >= 0.0 && max_scale_change < 1.0)) {
    throw std::invalid_argument("image shift max_scale_change must be in [0, 1)");
  }
  if (!(max_chance_probability > 0.0 && max_chance_probability <= 1.0)) {
    throw std::invalid_argument("image shift max_chance_probability must be in (0, 1]");
  }
}

double poissonUpperTail(int k, double mean) {
  if (!(mean >= 0.0) || static_cast<double>(k) <= mean) return 1.0;
  // e^-mean Σ_{i >= k} mean^i / i!, from the first term on (the terms fall for i > mean).
  double term = std::exp(-mean + k * std::log(std::max(mean, 1e-300)) - std::lgamma(k + 1.0));
  double sum = 0.0;
  for (int i = k; term > 1e-18 * sum && i < k + 10000; ++i) {
    sum += term;
    term *= mean / (i + 1.0);
  }
  return std::min(1.0, sum);
}

namespace {

// For sorted values: the first index and the count of the fullest window [v_i, v_i + width].
struct Window {
  std::size_t first = 0;
  int count = 0;
};

Window fullestWindow(const std::vector<double>& sorted, double width, double exclude_from, double exclude_to) {
  Window best;
  std::size_t end = 0;
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    end = std::max(end, i);
    while (end < sorted.size() && sorted[end] - sorted[i] <= width) ++end;
    const double centre = 0.5 * (sorted[i] + sorted[end - 1]);
    if (centre >= exclude_from && centre <= exclude_to) continue;
    const int count = static_cast<int>(end - i);
    if (count > best.count) best = Window{i, count};
  }
  return best;
}

}  // namespace

Expected<ImageShift> estimateImageShift(const PointMatches& matches, int image_width,
                                        const ImageShiftOptions& options, std::optional<double> centre_x,
                                        std::optional<double> focal_px) {
  options.validate();
  if (image_width <= 0) return Status(StatusCode::kInvalidInput, "image width must be > 0");
  if (centre_x && !std::isfinite(*centre_x)) return Status(StatusCode::kInvalidInput, "the centre x is not finite");
  if (focal_px && !(*focal_px > 0.0 && std::isfinite(*focal_px))) {
    return Status(StatusCode::kInvalidInput, "the focal length must be finite and > 0");
  }
  // With a focal length the vote runs on f·atan(x/f) (angles in pixels at the centre), where a
  // rotation is exactly a shift; the result goes back to pixels at the centre, f·tan(shift/f).
  const auto angular = [&](double centred_x) { return focal_px ? *focal_px * std::atan(centred_x / *focal_px) : centred_x; };
  const double window = options.window_fraction * image_width;
  const double vertical_limit = options.vertical_limit_fraction * image_width;
  const double centre = centre_x ? *centre_x : 0.5 * image_width;
  std::vector<double> dx, x;  // x difference and reference x (from the image centre)
  dx.reserve(matches.size());
  x.reserve(matches.size());
  for (const PointMatch& m : matches) {
    if (!m.reference.allFinite() || !m.current.allFinite()) {
      return Status(StatusCode::kInvalidInput, "a match has a non-finite pixel");
    }
    if (std::abs(m.current.y() - m.reference.y()) > vertical_limit) continue;
    const double reference_x = angular(m.reference.x() - centre);
    dx.push_back(angular(m.current.x() - centre) - reference_x);
    x.push_back(reference_x);
  }
  ImageShift shift;
  shift.matches = static_cast<int>(dx.size());
  if (shift.matches < options.min_support) {
    return Status(StatusCode::kTooFewPoints, std::to_string(shift.matches) + " matches within the vertical limit, " +
                                                 std::to_string(options.min_support) + " needed");
  }
  // The vote over the scale: the shift at the image centre of every match, were the view scaled
  // by s about the centre (dx = shift + (s − 1) x); scales 1.02^k, k = 0, ±1, ±2, ... within
  // max_scale_change, the scale nearest 1 winning a tie.
  const int steps = options.max_scale_change > 0.0
                        ? static_cast<int>(std::floor(std::log1p(options.max_scale_change) / std::log(1.02) + 1e-9))
                        : 0;
  std::vector<double> centred(dx.size()), best_centred;
  Window best;
  double best_scale = 1.0;
  for (int i = 0; i <= 2 * steps; ++i) {
    const int k = (i % 2 == 0 ? 1 : -1) * ((i + 1) / 2);  // 0, -1, 1, -2, 2, ...
    const double scale = std::pow(1.02, k);
    for (std::size_t j = 0; j < dx.size(); ++j) centred[j] = dx[j] - (scale - 1.0) * x[j];
    std::sort(centred.begin(), centred.end());
    const Window window_here = fullestWindow(centred, window, 1.0, 0.0);  // nothing excluded
    if (window_here.count > best.count) {
      best = window_here;
      best_scale = scale;
      best_centred = centred;
    }
  }
  if (best.count < options.min_support) {
    return Status(StatusCode::kNoConsensus, "at most " + std::to_string(best.count) + " of " +
                                                std::to_string(shift.matches) + " matches agree on a shift");
  }
  // Within the window, wrong matches fall uniformly and the right ones about their shift: the
  // median, then the matches within 3 robust σ (1.4826 MAD, at least 0.5 px) of it.
  std::vector<double> in_window(best_centred.begin() + static_cast<std::ptrdiff_t>(best.first),
                                best_centred.begin() + static_cast<std::ptrdiff_t>(best.first) + best.count);
  const double median = in_window[in_window.size() / 2];
  std::vector<double> deviations;
  deviations.reserve(in_window.size());
  for (const double d : in_window) deviations.push_back(std::abs(d - median));
  std::nth_element(deviations.begin(), deviations.begin() + static_cast<std::ptrdiff_t>(deviations.size() / 2),
                   deviations.end());
  const double robust_sigma = std::max(0.5, 1.4826 * deviations[deviations.size() / 2]);
  double sum = 0.0;
  int kept = 0;
  for (const double d : in_window) {
    if (std::abs(d - median) > 3.0 * robust_sigma) continue;
    sum += d;
    ++kept;
  }
  shift.support = kept;
  shift.shift_px = sum / kept;
  shift.scale = best_scale;
  double squares = 0.0;
  for (const double d : in_window) {
    if (std::abs(d - median) <= 3.0 * robust_sigma) squares += (d - shift.shift_px) * (d - shift.shift_px);
  }
  shift.spread_px = kept > 1 ? std::sqrt(squares / (kept - 1)) : 0.0;
  shift.sigma_px = shift.spread_px / std::sqrt(static_cast<double>(kept));
  // Chance: the vote's range is the image's width (in angles, f·atan at both edges).
  const double range = angular(image_width - centre) - angular(-centre);
  shift.chance_support = shift.matches * window / range;
  shift.chance_probability = poissonUpperTail(kept, shift.chance_support);
  if (shift.chance_probability > options.max_chance_probability) {
    char message[200];
    std::snprintf(message, sizeof(message),
                  "%d of %d matches agree on a shift, as many as chance puts in a window with probability %.1e "
                  "(max_chance_probability %.0e)",
                  kept, shift.matches, shift.chance_probability, options.max_chance_probability);
    return Status(StatusCode::kNoConsensus, message);
  }
  const Window runner_up = fullestWindow(best_centred, window, shift.shift_px - window, shift.shift_px + window);
  shift.runner_up_support = runner_up.count;
  shift.runner_up_shift_px = runner_up.count > 0 ? best_centred[runner_up.first + runner_up.count / 2] : NAN;
  if (focal_px) {
    const double t = std::tan(shift.shift_px / *focal_px);
    const double slope = 1.0 + t * t;  // d(f tan(a/f))/da
    shift.shift_px = *focal_px * t;
    shift.runner_up_shift_px = *focal_px * std::tan(shift.runner_up_shift_px / *focal_px);
    shift.spread_px *= slope;
    shift.sigma_px *= slope;
  }
  return shift;
}

}  // namespace homography_teach_repeat
