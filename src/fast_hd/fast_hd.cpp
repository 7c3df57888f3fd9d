#include "homography_teach_repeat/fast_hd/fast_hd.h"

#include <cmath>

namespace homography_teach_repeat {
namespace {
// Relative size below which κ counts as zero: H at any scale, so compare with |H|.
constexpr double kKappaRelativeTolerance = 1e-9;
}  // namespace

Expected<FastHdSolution> solveFastHd(const Eigen::Matrix3d& H, const PinholeCamera& camera,
                                     const ScenePlane& plane) {
  if (!H.allFinite()) return Status(StatusCode::kNotFinite, "homography has NaN/Inf entries");
  const Status plane_status = plane.validate();
  if (!plane_status.isOk()) return plane_status;

  const double fu = camera.fx();
  const double u0 = camera.cx();
  const double v0 = camera.cy();
  // docs/math.md §1.3: κ = H(2,2) − v0 H(3,2) (1-based) = H[1][1] − v0 H[2][1].
  const double kappa = H(1, 1) - v0 * H(2, 1);
  if (!(std::abs(kappa) > kKappaRelativeTolerance * H.norm())) {
    return Status(StatusCode::kDegenerate,
                  "κ = H(2,2) − v0·H(3,2) is zero: not a homography of planar motion");
  }
  const Eigen::Matrix3d Hn = H / kappa;

  // docs/math.md §1.4, corrected eq. (4).
  const double c11 = Hn(0, 0) - u0 * Hn(2, 0);
  const double c31 = fu * Hn(2, 0);
  const double c33 = u0 * Hn(2, 0) + v0 * Hn(2, 1) + Hn(2, 2);
  const double c13 = (u0 * Hn(0, 0) + v0 * Hn(0, 1) + Hn(0, 2) - u0 * c33) / fu;
  const double d1 = plane.distance;
  const double b1 = d1 * c11, b2 = d1 * c13, b3 = d1 * c31, b4 = d1 * c33;

  // Closed-form inverse of Π (docs/math.md §1.4).
  const double nx = plane.normal.x();
  const double nz = plane.normal.z();
  const double n_squared = nx * nx + nz * nz;
  FastHdSolution solution;
  solution.kappa = kappa;
  solution.x21 = (nx * (b4 - b1) - nz * (b2 + b3)) / n_squared;
  solution.z21 = (-nz * (b4 - b1) - nx * (b2 + b3)) / n_squared;
  solution.sin_theta21 = (b3 + nx * solution.z21) / d1;
  solution.cos_theta21 = (b1 + nx * solution.x21) / d1;
  const double theta21 = std::atan2(solution.sin_theta21, solution.cos_theta21);

  // docs/math.md §1.6: pose of camera 2 in the reference frame.
  const double c = std::cos(theta21);
  const double s = std::sin(theta21);
  solution.pose = PlanarPose(c * solution.x21 + s * solution.z21,
                             -s * solution.x21 + c * solution.z21, -theta21);
  if (!solution.pose.isFinite()) {
    return Status(StatusCode::kNotFinite, "Fast-HD produced a non-finite pose");
  }
  return solution;
}

}  // namespace homography_teach_repeat
