// libFuzzer target: parameter validation. Arbitrary values (NaN, Inf, negative, huge) go into an
// options struct; validate() must either throw std::invalid_argument or accept values the code
// then runs with: a controller whose commands stay finite and within their limits, a gate, the
// line extractor, the 1D homography's LMedS, the trifocal RANSAC, the matcher.
#include <opencv2/core.hpp>

#include "fuzz_support.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/mu/homography_1d.h"
#include "homography_teach_repeat/localization/odometry_gate.h"
#include "homography_teach_repeat/control/potential_field_controller.h"
#include "homography_teach_repeat/eval/synthetic_bearing_scene.h"
#include "homography_teach_repeat/trifocal/trifocal_ransac.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace htr = homography_teach_repeat;
using htr_fuzz::anyDouble;
using htr_fuzz::anyInt;

namespace {

void check(bool holds) {
  if (!holds) __builtin_trap();
}

void controller(FuzzedDataProvider& in) {
  htr::PotentialFieldParameters p;
  for (double* field : {&p.viscous_friction, &p.inertia_ratio, &p.lever, &p.attractive_gain,
                        &p.attraction_saturation, &p.repulsive_gain, &p.repulsive_range, &p.max_linear_velocity,
                        &p.max_angular_velocity, &p.max_linear_acceleration, &p.max_angular_acceleration,
                        &p.goal_tolerance, &p.goal_heading_tolerance}) {
    if (in.ConsumeBool()) *field = anyDouble(in);
  }
  p.allow_reverse = in.ConsumeBool();
  try {
    p.validate();
  } catch (const std::invalid_argument&) {
    return;
  }
  htr::PotentialFieldController controller(p);
  for (int k = 0; k < 20 && in.remaining_bytes() > 0; ++k) {
    std::vector<Eigen::Vector2d> obstacles(in.ConsumeIntegralInRange<std::size_t>(0, 3));
    for (auto& o : obstacles) o = Eigen::Vector2d(anyDouble(in), anyDouble(in));
    const auto command = in.ConsumeBool() ? controller.step(anyDouble(in), anyDouble(in), obstacles, anyDouble(in))
                                          : controller.track(anyDouble(in), anyDouble(in), anyDouble(in));
    const htr::VelocityCommand& state = command ? *command : controller.state();
    // Validated parameters: the command is finite and within the base's limits, whatever the input.
    check(std::isfinite(state.linear) && std::isfinite(state.angular));
    check(std::abs(state.linear) <= p.max_linear_velocity * (1 + 1e-9));
    check(std::abs(state.angular) <= p.max_angular_velocity * (1 + 1e-9));
    if (!p.allow_reverse) check(state.linear >= -1e-12);
  }
}

void gate(FuzzedDataProvider& in) {
  htr::OdometryGateOptions o;
  for (double* field : {&o.position_tolerance, &o.heading_tolerance, &o.drift_fraction, &o.heading_drift_per_metre,
                        &o.rotation_drift_fraction, &o.window}) {
    if (in.ConsumeBool()) *field = anyDouble(in);
  }
  if (in.ConsumeBool()) o.switch_after = anyInt(in);
  try {
    htr::OdometryGate gate(o);
    for (int k = 0; k < 10 && in.remaining_bytes() > 0; ++k) {
      (void)gate.check(htr::Pose2D(anyDouble(in), anyDouble(in), anyDouble(in)),
                       htr::Pose2D(anyDouble(in), anyDouble(in), anyDouble(in)));
    }
  } catch (const std::invalid_argument&) {
  }
}

void lines(FuzzedDataProvider& in) {
  htr::VerticalLineOptions o;
  o.max_angle_deg = anyDouble(in);
  o.min_length_px = anyInt(in);
  o.min_gradient = anyDouble(in);
  o.max_step_px = anyDouble(in);
  o.max_row_gap = anyInt(in);
  o.max_fit_rms_px = anyDouble(in);
  o.brightness_offset_px = anyInt(in);
  try {
    htr::VerticalLineExtractor extractor(o);
    cv::Mat image(60, 80, CV_8UC1, cv::Scalar(40));
    image.colRange(20, 50).setTo(220);
    const auto found = extractor.extract(image);
    check(found.isOk());
  } catch (const std::invalid_argument&) {
  }
}

void homography1d(FuzzedDataProvider& in) {
  htr::Homography1dOptions o;
  o.failure_probability = anyDouble(in);
  o.inlier_probability = anyDouble(in);
  o.seed = in.ConsumeIntegral<unsigned>();
  try {
    o.validate();
  } catch (const std::invalid_argument&) {
    return;
  }
  if (o.subsetCount() > 100000) return;  // valid but slow (Pns near 0): not this target's business
  std::vector<htr::LineCorrespondence> correspondences;
  for (int k = 0; k < 12; ++k) correspondences.push_back({40.0 * k, 40.0 * k + 3.0 + (k % 5 == 0 ? 60.0 : 0.0)});
  (void)htr::estimateHomography1dLmeds(correspondences, o);
}

void trifocalRansac(FuzzedDataProvider& in) {
  htr::TrifocalRansacOptions o;
  o.method = static_cast<htr::TrifocalMethod>(in.ConsumeIntegralInRange<int>(0, 2));
  o.max_transfer_error = anyDouble(in);
  o.confidence = anyDouble(in);
  o.max_iterations = in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(-2, 300) : anyInt(in);
  o.max_growth_rounds = in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(-2, 8) : anyInt(in);
  o.seed = in.ConsumeIntegral<unsigned>();
  try {
    o.validate();
  } catch (const std::invalid_argument&) {
    return;
  }
  o.max_iterations = std::min(o.max_iterations, 300);  // valid but slow: not this target's business
  o.max_growth_rounds = std::min(o.max_growth_rounds, 8);
  std::mt19937 rng(o.seed);
  const auto motion = htr::movementB();
  auto scene = htr::randomBearingScene(motion, htr::LineCamera1d(), 30, htr::BearingSceneOptions{}, rng);
  (void)htr::estimateTrifocalRansac(scene.triplets, o);
}

void matcher(FuzzedDataProvider& in) {
  htr::MatchOptions o;
  o.ratio = anyDouble(in);
  o.mutual = in.ConsumeBool();
  try {
    o.validate();
  } catch (const std::invalid_argument&) {
    return;
  }
  htr::ImageFeatures a, b;
  a.type = b.type = htr::FeatureType::kOrb;
  a.descriptors = cv::Mat(5, 32, CV_8UC1);
  b.descriptors = cv::Mat(6, 32, CV_8UC1);
  for (cv::Mat* d : {&a.descriptors, &b.descriptors}) {
    for (int k = 0; k < d->rows * d->cols; ++k) d->data[k] = in.ConsumeIntegral<std::uint8_t>();
  }
  a.keypoints.resize(5);
  b.keypoints.resize(6);
  (void)htr::matchFeatures(a, b, o);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  switch (in.ConsumeIntegralInRange<int>(0, 5)) {
    case 0: controller(in); break;
    case 1: gate(in); break;
    case 2: lines(in); break;
    case 3: homography1d(in); break;
    case 4: trifocalRansac(in); break;
    default: matcher(in); break;
  }
  return 0;
}
