#include "homography_teach_repeat/mu/line_landmarks.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {
namespace {

constexpr double kMinProjectionDepth = 0.1;  // [m]
// A second candidate within this factor of the best one's reprojection RMS (plus the pixel noise)
// makes a line ambiguous.
constexpr double kAmbiguityRatio = 2.0;

void requirePositive(double value, const char* name) {
  if (!std::isfinite(value) || !(value > 0.0)) {
    throw std::invalid_argument(std::string("line landmarks: ") + name + " must be finite and > 0");
  }
}

// One observation of a landmark: the view's camera and the line's x.
struct Ray {
  PlanarPose camera;
  double x = 0.0;
};

// The ray's direction in the keyframe frame (camera-z component 1 in its own frame).
Eigen::Vector2d directionOf(const Ray& ray, const LineCamera& lens) {
  const double c = std::cos(ray.camera.theta), s = std::sin(ray.camera.theta);
  const double u = (ray.x - lens.x0) / lens.f;
  return Eigen::Vector2d(c * u - s, s * u + c);  // R2(θ) (u, 1)
}

// Where two rays meet, in front of both within the depth range (the depth along each camera's axis
// is the ray parameter: the direction's own z is 1).
std::optional<Eigen::Vector2d> intersect(const Ray& a, const Ray& b, const LineCamera& lens,
                                         const LineLandmarkOptions& options) {
  const Eigen::Vector2d da = directionOf(a, lens), db = directionOf(b, lens);
  Eigen::Matrix2d A;
  A << da, -db;
  const double det = A.determinant();
  if (!(std::abs(det) > 1e-9)) return std::nullopt;  // parallel: no parallax
  const Eigen::Vector2d st = A.inverse() * (Eigen::Vector2d(b.camera.x, b.camera.z) - Eigen::Vector2d(a.camera.x, a.camera.z));
  for (int i = 0; i < 2; ++i) {
    if (!(st(i) >= options.min_depth_m && st(i) <= options.max_depth_m)) return std::nullopt;
  }
  return Eigen::Vector2d(a.camera.x, a.camera.z) + st(0) * da;
}

// ∂x/∂position of the projection (docs/math.md §4.8).
Eigen::RowVector2d projectionJacobian(const PlanarPose& camera, const Eigen::Vector2d& position, const LineCamera& lens) {
  const Eigen::Vector2d local = camera.inverse().transformPoint(position);
  const double c = std::cos(camera.theta), s = std::sin(camera.theta);
  Eigen::Matrix2d Rt;  // R2(θ)ᵀ
  Rt << c, s, -s, c;
  const Eigen::RowVector2d d_local(lens.f / local.y(), -lens.f * local.x() / (local.y() * local.y()));
  return d_local * Rt;
}

struct Refined {
  Eigen::Vector2d position;
  Eigen::Matrix2d information;  // JᵀJ [1/m²·px²]
  double rms_px = 0.0;
  double worst_px = 0.0;
};

// Gauss-Newton on the image x of every ray from `start`.
std::optional<Refined> refine(const std::vector<Ray>& rays, Eigen::Vector2d position, const LineCamera& lens) {
  for (int iteration = 0; iteration < 8; ++iteration) {
    Eigen::Matrix2d JtJ = Eigen::Matrix2d::Zero();
    Eigen::Vector2d Jtr = Eigen::Vector2d::Zero();
    for (const Ray& ray : rays) {
      const auto x = projectLineLandmark(ray.camera, position, lens);
      if (!x) return std::nullopt;
      const Eigen::RowVector2d J = projectionJacobian(ray.camera, position, lens);
      JtJ += J.transpose() * J;
      Jtr += J.transpose() * (ray.x - *x);
    }
    const Eigen::Vector2d step = JtJ.ldlt().solve(Jtr);
    if (!step.allFinite()) return std::nullopt;
    position += step;
    if (step.norm() < 1e-7 * (1.0 + position.norm())) break;
  }
  Refined refined;
  refined.position = position;
  refined.information.setZero();
  double squares = 0.0;
  for (const Ray& ray : rays) {
    const auto x = projectLineLandmark(ray.camera, position, lens);
    if (!x) return std::nullopt;
    const double residual = ray.x - *x;
    squares += residual * residual;
    refined.worst_px = std::max(refined.worst_px, std::abs(residual));
    const Eigen::RowVector2d J = projectionJacobian(ray.camera, position, lens);
    refined.information += J.transpose() * J;
  }
  refined.rms_px = std::sqrt(squares / static_cast<double>(rays.size()));
  return refined;
}

// Where a line is looked for in a view: near `x`, within `tolerance` [px].
struct SearchWindow {
  double x = 0.0;
  double tolerance = 0.0;
};

// The line of `view` nearest to the window's x that looks like `line`, within the window.
const VerticalLine* nearestLine(const LineView& view, const VerticalLine& line, const SearchWindow& window,
                                const LineLandmarkOptions& options) {
  const VerticalLine* best = nullptr;
  double best_distance = window.tolerance;
  for (const VerticalLine& candidate : *view.lines) {
    const double distance = std::abs(candidate.x - window.x);
    if (distance <= best_distance && lineAppearanceAgrees(line, candidate, options.max_brightness_difference)) {
      best = &candidate;
      best_distance = distance;
    }
  }
  return best;
}

}  // namespace

void LineLandmarkOptions::validate() const {
  requirePositive(pixel_sigma_px, "pixel_sigma_px");
  requirePositive(max_reprojection_px, "max_reprojection_px");
  requirePositive(min_depth_m, "min_depth_m");
  requirePositive(max_depth_m, "max_depth_m");
  if (!(max_depth_m > min_depth_m)) throw std::invalid_argument("line landmarks: max_depth_m must exceed min_depth_m");
  requirePositive(max_brightness_difference, "max_brightness_difference");
  requirePositive(max_relative_sigma, "max_relative_sigma");
  if (min_views < 3) throw std::invalid_argument("line landmarks: min_views must be >= 3 (two rays always meet)");
}

bool lineAppearanceAgrees(const VerticalLine& a, const VerticalLine& b, double max_difference) {
  return a.polarity == b.polarity && std::abs(a.left_brightness - b.left_brightness) <= max_difference &&
         std::abs(a.right_brightness - b.right_brightness) <= max_difference;
}

Expected<double> projectLineLandmark(const PlanarPose& camera, const Eigen::Vector2d& position, const LineCamera& lens) {
  const Eigen::Vector2d local = camera.inverse().transformPoint(position);
  if (!(local.y() > kMinProjectionDepth)) {
    return Status(StatusCode::kDegenerate, "line landmark behind the camera");
  }
  return lens.x0 + lens.f * local.x() / local.y();
}

Expected<std::vector<LineLandmark>> triangulateLineLandmarks(const std::vector<VerticalLine>& lines,
                                                             const std::vector<LineView>& others,
                                                             const LineCamera& lens,
                                                             const LineLandmarkOptions& options) {
  const Status camera_ok = lens.validate();
  if (!camera_ok.isOk()) return camera_ok;
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  for (const LineView& view : others) {
    if (view.lines == nullptr || !view.camera.isFinite()) {
      return Status(StatusCode::kInvalidInput, "line landmarks: a view without lines or with a non-finite pose");
    }
  }
  std::vector<LineLandmark> landmarks;
  if (static_cast<int>(others.size()) + 1 < options.min_views) return landmarks;
  const double search_tolerance = 2.0 * options.max_reprojection_px;
  for (std::size_t a = 0; a < lines.size(); ++a) {
    const VerticalLine& line = lines[a];
    if (!std::isfinite(line.x)) continue;
    const Ray keyframe_ray{PlanarPose(), line.x};
    // Candidates from each view in turn (a line leaving the image forwards is still in the views
    // behind); the first view with a verified candidate decides.
    std::optional<std::vector<Ray>> chosen;
    bool ambiguous = false;
    for (std::size_t first = 0; first < others.size() && !chosen && !ambiguous; ++first) {
      std::vector<std::vector<Ray>> verified;
      for (const VerticalLine& candidate : *others[first].lines) {
        if (!lineAppearanceAgrees(line, candidate, options.max_brightness_difference)) continue;
        const Ray candidate_ray{others[first].camera, candidate.x};
        const auto meeting = intersect(keyframe_ray, candidate_ray, lens, options);
        if (!meeting) continue;
        std::vector<Ray> rays{keyframe_ray, candidate_ray};
        for (std::size_t v = 0; v < others.size(); ++v) {
          if (v == first) continue;
          const auto x = projectLineLandmark(others[v].camera, *meeting, lens);
          if (!x) continue;
          const VerticalLine* seen = nearestLine(others[v], line, SearchWindow{*x, search_tolerance}, options);
          if (seen) rays.push_back(Ray{others[v].camera, seen->x});
        }
        if (static_cast<int>(rays.size()) >= options.min_views) verified.push_back(std::move(rays));
      }
      if (verified.empty()) continue;
      // Several verified candidates (a row of windows, a dense texture: some line lies within the
      // search tolerance of most projections): the one seen in most views and, among those, the
      // one that fits best; none when a second fits as many views nearly as well.
      struct Fit {
        std::size_t candidate;
        double rms_px;
      };
      std::vector<Fit> fits;
      for (std::size_t c = 0; c < verified.size(); ++c) {
        const auto start = intersect(verified[c][0], verified[c][1], lens, options);
        const auto fitted = start ? refine(verified[c], *start, lens) : std::nullopt;
        if (fitted) fits.push_back(Fit{c, fitted->rms_px});
      }
      if (fits.empty()) continue;
      const auto better = [&](const Fit& a, const Fit& b) {
        const std::size_t views_a = verified[a.candidate].size(), views_b = verified[b.candidate].size();
        return views_a != views_b ? views_a > views_b : a.rms_px < b.rms_px;
      };
      std::sort(fits.begin(), fits.end(), better);
      if (fits.size() > 1 && verified[fits[1].candidate].size() == verified[fits[0].candidate].size() &&
          fits[1].rms_px < kAmbiguityRatio * fits[0].rms_px + options.pixel_sigma_px) {
        ambiguous = true;
      } else {
        chosen = std::move(verified[fits[0].candidate]);
      }
    }
    if (!chosen) continue;
    const auto start = intersect((*chosen)[0], (*chosen)[1], lens, options);
    if (!start) continue;
    auto refined = refine(*chosen, *start, lens);
    if (!refined) continue;
    if (refined->worst_px > options.max_reprojection_px) {
      // Drop the views that disagree with the others and refine once more.
      std::vector<Ray> kept{(*chosen)[0]};
      for (std::size_t r = 1; r < chosen->size(); ++r) {
        const auto x = projectLineLandmark((*chosen)[r].camera, refined->position, lens);
        if (x && std::abs((*chosen)[r].x - *x) <= options.max_reprojection_px) kept.push_back((*chosen)[r]);
      }
      if (static_cast<int>(kept.size()) < options.min_views) continue;
      refined = refine(kept, refined->position, lens);
      if (!refined || refined->worst_px > options.max_reprojection_px) continue;
      chosen = std::move(kept);
    }
    const double depth = refined->position.y();
    if (!(depth >= options.min_depth_m && depth <= options.max_depth_m)) continue;
    const Eigen::Matrix2d covariance =
        options.pixel_sigma_px * options.pixel_sigma_px * refined->information.inverse();
    if (!covariance.allFinite()) continue;
    const double largest_sigma = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(covariance).eigenvalues()(1));
    if (!(largest_sigma <= options.max_relative_sigma * depth)) continue;
    LineLandmark landmark;
    landmark.line = static_cast<int>(a);
    landmark.position = refined->position;
    landmark.covariance = covariance;
    landmark.views = static_cast<int>(chosen->size());
    landmark.rms_px = refined->rms_px;
    landmarks.push_back(landmark);
  }
  return landmarks;
}

}  // namespace homography_teach_repeat
