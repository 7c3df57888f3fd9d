#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/fast_hd/plane_estimation.h"

#include <Eigen/LU>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <optional>
#include <limits>
#include <string>

#include "homography_teach_repeat/geometry/camera_tilt.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/homography_decomposition.h"

namespace homography_teach_repeat {
namespace {

double planarityError(const HomographyDecomposition& d) {
  return std::max(std::abs(d.rotation21(1, 1) - 1.0), std::abs(d.translation_over_distance.y()));
}

// Distance of a candidate motion to the odometry motion: position [m] plus heading [rad] scaled
// by the baseline so both terms have comparable size.
double motionDistance(const PlanarPose& a, const PlanarPose& b) {
  const double baseline = std::max(std::hypot(b.x, b.z), 1e-3);
  return std::hypot(a.x - b.x, a.z - b.z) / baseline + std::abs(wrapToPi(a.theta - b.theta));
}

double kappaOf(const Eigen::Matrix3d& H, const PinholeCamera& camera) {
  return H(1, 1) - camera.cy() * H(2, 1);
}

}  // namespace

Expected<PlaneAndMotion> estimateFirstPlane(const Eigen::Matrix3d& H21, const PinholeCamera& camera,
                                            const std::vector<Eigen::Vector2d>& reference_pixels,
                                            double first_plane_distance,
                                            const PlanarPose* odometry_motion,
                                            const Eigen::Matrix3d* H31,
                                            const FirstPlaneOptions& options) {
  if (!(first_plane_distance > 0.0) || !std::isfinite(first_plane_distance)) {
    return Status(StatusCode::kInvalidInput, "first_plane_distance must be > 0");
  }
  if (reference_pixels.empty()) {
    return Status(StatusCode::kInvalidInput, "the positive-depth test needs reference pixels");
  }
  const auto all = decomposeHomographyClassic(H21, camera);
  if (!all) return all.status();
  std::vector<HomographyDecomposition> visible =
      filterByPositiveDepth(*all, camera, reference_pixels);
  PlaneAndMotion result;
  result.candidates_after_depth_test = static_cast<int>(visible.size());
  if (visible.empty()) {
    return Status(StatusCode::kDegenerate, "no decomposition puts every point in front");
  }
  std::sort(visible.begin(), visible.end(), [](const auto& a, const auto& b) {
    return planarityError(a) < planarityError(b);
  });
  std::vector<HomographyDecomposition> planar;
  for (const auto& d : visible) {
    if (planarityError(d) < options.planar_motion_tolerance) planar.push_back(d);
  }
  result.candidates_after_planar_test = static_cast<int>(planar.size());
  if (planar.empty()) {
    return Status(StatusCode::kDegenerate,
                  "no decomposition is a planar motion (camera not level, or not a plane)");
  }
  const HomographyDecomposition* chosen = &planar.front();
  // Exact data give planarity errors at rounding level; the floor keeps two such solutions a tie.
  constexpr double kPlanarityFloor = 1e-9;
  const bool tie = planar.size() > 1 &&
                   planarityError(planar[1]) <
                       options.tie_ratio * std::max(planarityError(planar[0]), kPlanarityFloor);
  if (tie && odometry_motion != nullptr) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& d : planar) {
      const double distance =
          motionDistance(d.planarPose(first_plane_distance), *odometry_motion);
      if (distance < best) {
        best = distance;
        chosen = &d;
      }
    }
    result.resolved_by_odometry = true;
  } else if (tie && H31 != nullptr) {
    const auto third = decomposeHomographyClassic(*H31, camera);
    if (!third) return third.status();
    std::vector<Eigen::Vector3d> third_normals;
    for (const auto& d : filterByPositiveDepth(*third, camera, reference_pixels)) {
      if (planarityError(d) < options.planar_motion_tolerance) third_normals.push_back(d.normal);
    }
    if (third_normals.empty()) {
      return Status(StatusCode::kDegenerate,
                    "two planar-motion solutions and the third view has none to compare");
    }
    double best = std::numeric_limits<double>::infinity();
    for (const auto& d : planar) {
      for (const auto& n : third_normals) {
        const double angle = std::acos(std::clamp(d.normal.normalized().dot(n.normalized()), -1.0, 1.0));
        if (angle < best) {
          best = angle;
          chosen = &d;
        }
      }
    }
    result.resolved_by_third_view = true;
  } else if (tie) {
    return Status(StatusCode::kDegenerate,
                  "two planar-motion solutions (vertical plane): odometry or a third view needed");
  }
  result.plane = chosen->plane(first_plane_distance);
  result.plane.normal.normalize();
  result.motion = chosen->planarPose(first_plane_distance);
  const Status plane_status = result.plane.validate();
  if (!plane_status.isOk()) return plane_status;
  return result;
}

Expected<ScenePlane> transferPlane(const ScenePlane& plane, const PlanarPose& pose) {
  if (!pose.isFinite()) return Status(StatusCode::kInvalidInput, "pose is not finite");
  ScenePlane next;
  next.normal = pose.rotation21() * plane.normal;
  next.distance = plane.distance - plane.normal.dot(pose.centre());
  if (!(next.distance > 0.0)) {
    return Status(StatusCode::kDegenerate,
                  "the next reference camera is on or behind the plane (d2 = " +
                      std::to_string(next.distance) + ")");
  }
  return next;
}

Expected<ScenePlane> estimateSecondPlane(const Eigen::Matrix3d& H_first,
                                         const Eigen::Matrix3d& H_second,
                                         const PinholeCamera& camera, const ScenePlane& first_plane,
                                         const PlanarPose& motion) {
  if (!H_first.allFinite() || !H_second.allFinite() || !motion.isFinite()) {
    return Status(StatusCode::kNotFinite, "homographies and motion must be finite");
  }
  const Eigen::Vector3d C = motion.centre();
  if (!(C.norm() > 1e-9)) {
    return Status(StatusCode::kDegenerate, "the homology needs a translation (C = 0)");
  }
  const double kappa1 = kappaOf(H_first, camera);
  const double kappa2 = kappaOf(H_second, camera);
  if (!(std::abs(kappa1) > 1e-12 * H_first.norm()) ||
      !(std::abs(kappa2) > 1e-12 * H_second.norm())) {
    return Status(StatusCode::kDegenerate, "κ is zero: not a homography of planar motion");
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(H_first / kappa1);
  if (!lu.isInvertible()) return Status(StatusCode::kDegenerate, "first homography is singular");
  // docs/math.md §2.3: H = (H¹)⁻¹ H² = I + v pᵀ, v = K C d1¹/d2¹.
  const Eigen::Matrix3d homology = lu.inverse() * (H_second / kappa2);
  const double d1 = first_plane.distance;
  const double d2 = d1 - first_plane.normal.dot(C);
  if (!(std::abs(d2) > 1e-9)) {
    return Status(StatusCode::kDegenerate, "the second camera lies on the first plane");
  }
  const Eigen::Vector3d v = camera.K() * C * (d1 / d2);
  // docs/math.md §2.4: pᵀ = vᵀ(H − I)/(vᵀv), m2 = n¹/d¹ − Kᵀp, n² = m2/|m2|, d² = 1/|m2|.
  const Eigen::Vector3d p =
      ((homology - Eigen::Matrix3d::Identity()).transpose() * v) / v.squaredNorm();
  const Eigen::Vector3d m2 = first_plane.normal / d1 - camera.K().transpose() * p;
  const double norm = m2.norm();
  if (!std::isfinite(norm)) return Status(StatusCode::kNotFinite, "second plane is not finite");
  if (!(norm > 1e-12)) {
    return Status(StatusCode::kDegenerate, "second plane is at infinity");
  }
  return ScenePlane{m2 / norm, 1.0 / norm};
}

Expected<RouteSequencePlanes> estimatePlanesAlongRoute(const std::vector<ReferencePair>& pairs,
                                                      const PinholeCamera& camera,
                                                      double first_plane_distance,
                                                      const FirstPlaneOptions& options) {
  if (pairs.empty()) {
    return Status(StatusCode::kTooFewPoints, "plane estimation needs at least two references");
  }
  const ReferencePair& first = pairs.front();
  Eigen::Matrix3d H20;
  const Eigen::Matrix3d* third_view = nullptr;
  if (pairs.size() > 1) {
    H20 = pairs[1].H_next_from_current * first.H_next_from_current;
    third_view = &H20;
  }
  const auto first_plane =
      estimateFirstPlane(first.H_next_from_current, camera, first.reference_pixels,
                         first_plane_distance, first.has_odometry ? &first.odometry_motion : nullptr,
                         third_view, options);
  if (!first_plane) {
    return Status(first_plane.status().code(),
                  "reference pair 0: " + first_plane.status().message());
  }
  RouteSequencePlanes route;
  route.planes.push_back(first_plane->plane);
  route.motions.push_back(first_plane->motion);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (k > 0) {
      const auto solution = solveFastHd(pairs[k].H_next_from_current, camera, route.planes.back());
      if (!solution) {
        return Status(solution.status().code(), "reference pair " + std::to_string(k) + ": " +
                                                    solution.status().message());
      }
      route.motions.push_back(solution->pose);
    }
    const auto next = transferPlane(route.planes.back(), route.motions.back());
    if (!next) {
      return Status(next.status().code(),
                    "reference " + std::to_string(k + 1) + ": " + next.status().message());
    }
    route.planes.push_back(*next);
  }
  return route;
}

Expected<ScenePlane> planeFromHomographyAndMotion(const Eigen::Matrix3d& H21, const PinholeCamera& camera,
                                                 const PlanarPose& motion, double min_baseline) {
  if (!H21.allFinite() || !motion.isFinite()) {
    return Status(StatusCode::kNotFinite, "homography and motion must be finite");
  }
  const Eigen::Matrix3d R21 = motion.rotation21();
  const Eigen::Vector3d t21 = R21 * motion.centre();
  if (!(t21.norm() >= min_baseline) || !(t21.norm() > 1e-12)) {
    return Status(StatusCode::kDegenerate, "the motion has no translation: the plane is not observable");
  }
  const double kappa = kappaOf(H21, camera);
  if (!(std::abs(kappa) > 1e-12 * H21.norm())) {
    return Status(StatusCode::kDegenerate, "κ is zero: not a homography of planar motion");
  }
  const Eigen::Matrix3d Hc = camera.Kinverse() * (H21 / kappa) * camera.K();
  const Eigen::Vector3d m = (R21 - Hc).transpose() * t21 / t21.squaredNorm();
  const double norm = m.norm();
  if (!std::isfinite(norm)) return Status(StatusCode::kNotFinite, "plane is not finite");
  if (!(norm > 1e-12)) return Status(StatusCode::kDegenerate, "plane at infinity");
  return ScenePlane{m / norm, 1.0 / norm};
}

Expected<PlaneAndTilt> planeAndTiltFromHomographyAndMotion(const Eigen::Matrix3d& H21, const PinholeCamera& camera,
                                                          const PlanarPose& motion, double min_baseline,
                                                          double max_tilt) {
  if (!H21.allFinite() || !motion.isFinite()) {
    return Status(StatusCode::kNotFinite, "homography and motion must be finite");
  }
  const Eigen::Matrix3d R21 = motion.rotation21();
  const Eigen::Vector3d C = motion.centre();
  if (!(C.norm() >= min_baseline) || !(C.norm() > 1e-12)) {
    return Status(StatusCode::kDegenerate, "the motion has no translation: the plane is not observable");
  }
  // docs/math.md §2.5: K⁻¹H21K = λ T R21 (I − C mᵀ), so across C (unit u ⊥ C) the plane drops out:
  // r_u(s, pitch, roll) = s (K⁻¹H21K)ᵀ T R21 u − u = 0 for both u, with s = 1/λ. Six equations in
  // three unknowns, solved by Gauss-Newton from the level camera (s from the linear fit).
  const Eigen::Vector3d u1 = C.unitOrthogonal();
  const Eigen::Vector3d u2 = C.normalized().cross(u1);
  const Eigen::Matrix3d Hc = camera.Kinverse() * H21 * camera.K();
  double scale = 0.0, pitch = 0.0, roll = 0.0;
  {
    const Eigen::Vector3d a1 = Hc.transpose() * R21 * u1, a2 = Hc.transpose() * R21 * u2;
    const double denominator = a1.squaredNorm() + a2.squaredNorm();
    if (!(denominator > 0.0)) return Status(StatusCode::kDegenerate, "the homography is zero across the motion");
    scale = (a1.dot(u1) + a2.dot(u2)) / denominator;
  }
  constexpr int kMaxIterations = 30;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const CameraTilt tilt = cameraTilt(pitch, roll);
    Eigen::Matrix<double, 6, 3> J;
    Eigen::Matrix<double, 6, 1> r;
    int row = 0;
    for (const Eigen::Vector3d& u : {u1, u2}) {
      const Eigen::Vector3d Ru = R21 * u;
      r.segment<3>(row) = scale * Hc.transpose() * tilt.T * Ru - u;
      J.block<3, 1>(row, 0) = Hc.transpose() * tilt.T * Ru;
      J.block<3, 1>(row, 1) = scale * Hc.transpose() * tilt.dT_dpitch * Ru;
      J.block<3, 1>(row, 2) = scale * Hc.transpose() * tilt.dT_droll * Ru;
      row += 3;
    }
    const Eigen::ColPivHouseholderQR<Eigen::Matrix<double, 6, 3>> qr(J);
    if (qr.rank() < 3) return Status(StatusCode::kDegenerate, "the tilt is not observable from this homography");
    const Eigen::Vector3d step = qr.solve(-r);
    if (!step.allFinite()) return Status(StatusCode::kNotFinite, "tilt estimation is not finite");
    scale += step(0);
    pitch += step(1);
    roll += step(2);
    if (std::abs(step(1)) + std::abs(step(2)) < 1e-15 && std::abs(step(0)) < 1e-15 * std::abs(scale)) break;
  }
  PlaneAndTilt result;
  result.pitch = pitch;
  result.roll = roll;
  if (!(std::abs(result.pitch) <= max_tilt) || !(std::abs(result.roll) <= max_tilt)) {
    return Status(StatusCode::kDegenerate, "the homography asks for a tilt of pitch " + std::to_string(result.pitch) +
                                               " rad, roll " + std::to_string(result.roll) + " rad (more than " +
                                               std::to_string(max_tilt) + ")");
  }
  const Eigen::Matrix3d levelled = camera.K() * result.tilt().transpose() * Hc * camera.Kinverse();
  const auto plane = planeFromHomographyAndMotion(levelled, camera, motion, min_baseline);
  if (!plane) return plane.status();
  result.plane = *plane;
  return result;
}

namespace {
// One pair's plane from its homography and odometry motion, with the pair's tilt when asked.
Expected<ScenePlane> planeOfPair(const ReferencePair& pair, const PinholeCamera& camera,
                                 const OdometryPlaneOptions& options) {
  if (!options.estimate_tilt) {
    return planeFromHomographyAndMotion(pair.H_next_from_current, camera, pair.odometry_motion, options.min_baseline);
  }
  const auto with_tilt =
      planeAndTiltFromHomographyAndMotion(pair.H_next_from_current, camera, pair.odometry_motion, options.min_baseline);
  if (!with_tilt) return with_tilt.status();
  return with_tilt->plane;
}
}  // namespace

bool isPlausibleWall(const ScenePlane& plane, const OdometryPlaneOptions& options) {
  return plane.validate().isOk() && plane.normal.z() > 0.0 && plane.distance < options.max_distance;
}

Expected<RouteSequencePlanes> estimatePlanesFromOdometry(const std::vector<ReferencePair>& pairs,
                                                        const PinholeCamera& camera,
                                                        const OdometryPlaneOptions& options) {
  if (pairs.empty()) return Status(StatusCode::kInvalidInput, "no reference pairs");
  RouteSequencePlanes result;
  std::vector<std::optional<ScenePlane>> planes(pairs.size() + 1);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (!pairs[k].has_odometry) {
      return Status(StatusCode::kInvalidInput, "pair " + std::to_string(k) + " has no odometry motion");
    }
    if (!pairs[k].has_homography) continue;
    const auto plane = planeOfPair(pairs[k], camera, options);
    if (plane && isPlausibleWall(*plane, options)) planes[k] = *plane;
  }
  // Where the pair before a keyframe turned clearly less than the pair after it, that pair's plane
  // carried into the keyframe (docs/math.md §2.6). From the estimates of the pairs themselves, so
  // that one choice does not feed the next.
  if (options.straighter_pair_margin >= 0.0) {
    const std::vector<std::optional<ScenePlane>> direct = planes;
    for (std::size_t k = 1; k < pairs.size(); ++k) {
      if (!direct[k] || !direct[k - 1]) continue;
      if (std::abs(pairs[k - 1].odometry_motion.theta) + options.straighter_pair_margin >=
          std::abs(pairs[k].odometry_motion.theta)) {
        continue;
      }
      const auto carried = transferPlane(*direct[k - 1], pairs[k - 1].odometry_motion);
      if (carried) planes[k] = *carried;
    }
  }
  // The keyframes whose plane comes from a pair (their own or the one before), before any filling.
  int last_estimated = -1;
  for (std::size_t k = 0; k < planes.size(); ++k) {
    if (planes[k]) last_estimated = static_cast<int>(k);
  }
  const bool first_estimated = planes[0].has_value();
  // Fill the gaps by transferring the previous plane along the motion (§2.2); before the first
  // estimate, backwards from the next one.
  for (std::size_t k = 1; k < planes.size(); ++k) {
    if (planes[k] || !planes[k - 1]) continue;
    const auto moved = transferPlane(*planes[k - 1], pairs[k - 1].odometry_motion);
    if (moved) planes[k] = *moved;
  }
  for (std::size_t k = planes.size() - 1; k-- > 0;) {
    if (planes[k] || !planes[k + 1]) continue;
    const auto moved = transferPlane(*planes[k + 1], pairs[k].odometry_motion.inverse());
    if (moved) planes[k] = *moved;
  }
  // A closed route's closing corner: the keyframes after the last estimate, from the last one
  // backwards, get the first keyframe's plane carried back where they face nearer its heading than
  // the last estimate's (§2.6).
  if (options.closing_motion && first_estimated && last_estimated > 0) {
    const int last = static_cast<int>(planes.size()) - 1;
    auto turnOfPair = [&](int j) { return pairs[static_cast<std::size_t>(j)].odometry_motion.theta; };
    double turn_from_last = 0.0;  // keyframe k's heading seen from the last estimate's
    for (int j = last_estimated; j < last; ++j) turn_from_last += turnOfPair(j);
    double turn_to_first = 0.0;  // the first keyframe's heading seen from keyframe k
    ScenePlane from_first = *planes[0];
    for (int k = last; k > last_estimated; --k) {
      const PlanarPose to_next = k == last ? *options.closing_motion : pairs[static_cast<std::size_t>(k)].odometry_motion;
      turn_to_first += to_next.theta;
      const auto carried = transferPlane(from_first, to_next.inverse());
      if (!carried) break;  // (the first wall behind this camera: not the wall it faces)
      from_first = *carried;
      if (std::abs(wrapToPi(turn_to_first)) < std::abs(wrapToPi(turn_from_last))) planes[k] = from_first;
      turn_from_last -= turnOfPair(k - 1);
    }
  }
  for (std::size_t k = 0; k < planes.size(); ++k) {
    if (!planes[k]) {
      return Status(StatusCode::kDegenerate, "no plane for keyframe " + std::to_string(k) +
                                                 ": no pair with enough baseline nearby");
    }
    result.planes.push_back(*planes[k]);
  }
  for (const auto& pair : pairs) result.motions.push_back(pair.odometry_motion);
  return result;
}

std::vector<PlaneMatchRating> ratePlaneMatches(const PointMatches& matches, const PinholeCamera& camera,
                                               const PlanarPose& motion, const ScenePlane& plane,
                                               double tolerance_px,
                                               const std::optional<RobustHomographyOptions>& tilt_fit) {
  Eigen::Matrix3d H = planeInducedHomography(camera, motion, plane);
  // The same views as if every point were at infinity: the rotation alone.
  Eigen::Matrix3d H_rotation = camera.K() * motion.rotation21() * camera.Kinverse();
  if (tilt_fit) {
    // The neighbour's camera is pitched and rolled against this one, and the planar-motion
    // homography misses the plane by several pixels (KITTI 07 with one constant mount: 1° between
    // keyframes, ~12 px).
    const auto pair = estimateHomographyRobust(matches, *tilt_fit);
    if (pair) {
      const auto tilt = planeAndTiltFromHomographyAndMotion(pair->H, camera, motion);
      if (tilt) {
        const Eigen::Matrix3d T = camera.K() * tilt->tilt() * camera.Kinverse();
        H = T * H;
        H_rotation = T * H_rotation;
      }
    }
  }
  std::vector<PlaneMatchRating> ratings;
  ratings.reserve(matches.size());
  for (const PointMatch& match : matches) {
    const Eigen::Vector2d on_the_plane = applyHomography(H, match.reference);
    if (!((match.current - on_the_plane).norm() < tolerance_px)) {
      ratings.push_back(PlaneMatchRating::kOffThePlane);
    } else {
      const bool parallax = (on_the_plane - applyHomography(H_rotation, match.reference)).norm() >=
                            kConfirmingParallax * tolerance_px;
      ratings.push_back(parallax ? PlaneMatchRating::kOnWithParallax : PlaneMatchRating::kOnWithoutParallax);
    }
  }
  return ratings;
}

}  // namespace homography_teach_repeat
