// libFuzzer target: the hand-written solvers on arbitrary numbers (NaN, Inf, zeros, huge values,
// repeated points): Fast-HD (docs/math.md §1.4), the 1D homography of vertical lines (DLT and LMedS)
// and the 1D trifocal tensor (TT7, TT5, TT4, RANSAC, closed-form motion, triangulation). Each must
// return a status or a finite result, never crash or trip a sanitizer.
#include <Eigen/Core>

#include "fuzz_support.h"
#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/mu/homography_1d.h"
#include "homography_teach_repeat/trifocal/trifocal_motion.h"
#include "homography_teach_repeat/trifocal/trifocal_ransac.h"
#include "homography_teach_repeat/trifocal/trifocal_tensor_1d.h"

namespace htr = homography_teach_repeat;

namespace {

void requireFinite(bool finite) {
  if (!finite) __builtin_trap();
}

void fastHd(FuzzedDataProvider& in) {
  Eigen::Matrix3d H;
  for (int k = 0; k < 9; ++k) H(k / 3, k % 3) = htr_fuzz::anyDouble(in);
  htr::CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = in.ConsumeBool() ? 500.0 : htr_fuzz::anyDouble(in);
  c.cx = 319.5;
  c.cy = in.ConsumeBool() ? 239.5 : htr_fuzz::anyDouble(in);
  htr::ScenePlane plane;
  plane.normal = Eigen::Vector3d(htr_fuzz::anyDouble(in), htr_fuzz::anyDouble(in), htr_fuzz::anyDouble(in));
  if (in.ConsumeBool() && plane.normal.allFinite() && plane.normal.norm() > 0.0) plane.normal.normalize();
  plane.distance = htr_fuzz::anyDouble(in);
  try {
    const htr::PinholeCamera camera(c);
    const auto solution = htr::solveFastHd(H, camera, plane);
    if (solution) requireFinite(solution->pose.isFinite());
  } catch (const std::invalid_argument&) {
  }
}

void homography1d(FuzzedDataProvider& in) {
  std::vector<htr::LineCorrespondence> lines(in.ConsumeIntegralInRange<std::size_t>(0, 30));
  for (auto& line : lines) {
    line.reference_x = htr_fuzz::anyDouble(in);
    line.current_x = in.ConsumeBool() ? line.reference_x + in.ConsumeFloatingPointInRange<double>(-5.0, 5.0)
                                      : htr_fuzz::anyDouble(in);
  }
  const auto dlt = htr::estimateHomography1dDlt(lines);
  if (dlt) {
    requireFinite(dlt->allFinite());
    for (const auto& line : lines) (void)htr::transferResidual1d(*dlt, line);
  }
  htr::Homography1dOptions options;
  options.inlier_probability = 0.5;
  const auto lmeds = htr::estimateHomography1dLmeds(lines, options);
  if (lmeds) requireFinite(lmeds->H.allFinite());
}

htr::Bearing anyBearing(FuzzedDataProvider& in) {
  if (in.ConsumeBool()) return htr::bearingFromAngle(in.ConsumeFloatingPointInRange<double>(-1.0, 1.0));
  return htr::Bearing(htr_fuzz::anyDouble(in), htr_fuzz::anyDouble(in));
}

void trifocal(FuzzedDataProvider& in) {
  std::vector<htr::BearingTriplet> triplets(in.ConsumeIntegralInRange<std::size_t>(0, 24));
  for (auto& t : triplets) t = {anyBearing(in), anyBearing(in), anyBearing(in)};
  const std::size_t on_plane = in.ConsumeIntegralInRange<std::size_t>(0, triplets.size());
  const std::vector<htr::BearingTriplet> on(triplets.begin(), triplets.begin() + static_cast<std::ptrdiff_t>(on_plane));
  const std::vector<htr::BearingTriplet> off(triplets.begin() + static_cast<std::ptrdiff_t>(on_plane), triplets.end());
  std::vector<htr::Expected<htr::TrifocalTensor1d>> tensors;
  tensors.push_back(htr::estimateTT7(triplets));
  tensors.push_back(htr::estimateTT5(triplets));
  tensors.push_back(htr::estimateTT4(on, off));
  htr::TrifocalRansacOptions options;
  options.method = static_cast<htr::TrifocalMethod>(in.ConsumeIntegralInRange<int>(0, 2));
  options.max_iterations = 200;
  const auto ransac = htr::estimateTrifocalRansac(triplets, options);
  if (ransac) tensors.push_back(ransac->tensor);
  for (const auto& T : tensors) {
    if (!T) continue;
    requireFinite(T->allFinite());
    for (const auto& t : triplets) (void)htr::transferError(*T, t);
    htr::TrifocalMotionPrior prior;
    prior.centre_second = Eigen::Vector2d(htr_fuzz::anyDouble(in), 1.0);
    prior.centre_third = Eigen::Vector2d(0.5, htr_fuzz::anyDouble(in));
    const auto motion = htr::estimateTrifocalMotion(*T, triplets, prior);
    if (!motion) continue;
    for (const auto& t : triplets) {
      const auto landmark = htr::triangulateLandmark(motion->motion, t);
      if (landmark) requireFinite(landmark->allFinite());
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  switch (in.ConsumeIntegralInRange<int>(0, 2)) {
    case 0: fastHd(in); break;
    case 1: homography1d(in); break;
    default: trifocal(in); break;
  }
  return 0;
}
