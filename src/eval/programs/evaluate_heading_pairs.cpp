// evaluate_heading_pairs: every heading measurement of the package on pairs of images of one place
// with the true horizontal shift between them (a GRIEF site folder of the seasonal benchmark, or a
// list file: eval/heading_pairs.h), scored by the benchmark's protocol (a pair fails when the
// estimate is missing or more than 35 px off). Writes OUT/heading_pairs.json and
// OUT/heading_pairs.png; prints the error rate per method last. docs/evaluation.md, "Heading across
// seasons".
//   evaluate_heading_pairs --data SITE_DIR|LIST_FILE --out DIR [--methods a,b] [--max-features 1600]
// Exit 2: bad arguments or data (named); 1: output not written.
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/atomic_file.h"
#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/common/process_memory.h"
#include "homography_teach_repeat/eval/heading_pairs.h"
#include "homography_teach_repeat/eval/plots.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/homography/image_registration.h"
#include "homography_teach_repeat/mu/heading_correction.h"
#include "homography_teach_repeat/mu/line_shift.h"
#include "homography_teach_repeat/mu/shift_heading.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

using namespace homography_teach_repeat;
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// What a method measures the shift with.
// kChain: the repeat's order (hybrid mode) as far as two images show it: the registration where it
// has at least RepeatOptions::min_inliers inliers (the repeat would then try its Fast-HD pose), the
// seasonal shift vote otherwise (mu/shift_heading.h).
enum class Estimator { kHomography, kVote, kLines, kLineVote, kChain };

struct Method {
  std::string name;
  std::string description;
  Estimator estimator = Estimator::kVote;
  std::vector<FeatureOptions> features;  // kVote: the matches of every set vote together (ShiftHeading)
  std::vector<FeatureOptions> vote_features;  // kChain: its vote's (features: its registration's)
};

std::vector<Method> allMethods(int max_features) {
  const auto set = [&](FeatureType type, bool upright) {
    FeatureOptions features;
    features.type = type;
    features.max_features = max_features;
    features.upright = upright;
    return features;
  };
  const FeatureOptions sift = set(FeatureType::kSift, false), upright_sift = set(FeatureType::kSift, true);
  const FeatureOptions akaze = set(FeatureType::kAkaze, false), upright_akaze = set(FeatureType::kAkaze, true);
  const FeatureOptions upright_orb = set(FeatureType::kOrb, true), brief = set(FeatureType::kBrief, true);
  const std::string vote = ", mutual nearest, shift vote";
  return {
      {"homography", "SIFT, ratio 0.8 + mutual, robust homography (the fast_hd chain): the shift of the image centre",
       Estimator::kHomography, {sift}, {}},
      {"sift_vote", "SIFT" + vote, Estimator::kVote, {sift}, {}},
      {"upright_sift_vote", "upright SIFT" + vote, Estimator::kVote, {upright_sift}, {}},
      {"akaze_vote", "AKAZE" + vote, Estimator::kVote, {akaze}, {}},
      {"upright_akaze_vote", "upright AKAZE" + vote, Estimator::kVote, {upright_akaze}, {}},
      {"upright_orb_vote", "upright ORB" + vote, Estimator::kVote, {upright_orb}, {}},
      {"brief_vote", "BRIEF on AGAST corners" + vote, Estimator::kVote, {brief}, {}},
      {"shift_heading", "the repeat's seasonal heading fix (mu/shift_heading.h): upright AKAZE and BRIEF, each mutual nearest, one shift vote",
       Estimator::kVote, ShiftHeadingOptions::defaultFeatures(), {}},
      {"upright_akaze_sift_brief_vote", "upright AKAZE, upright SIFT and BRIEF, each mutual nearest, one shift vote",
       Estimator::kVote, {upright_akaze, upright_sift, brief}, {}},
      {"mu_lines", "vertical lines, 1D homography (LMedS): mu", Estimator::kLines, {}, {}},
      {"mu_line_vote", "vertical lines (seasonal extraction), BRIEF along each line, mutual nearest, shift vote",
       Estimator::kLineVote, {}, {}},
      {"repeat_chain",
       "the repeat's order (hybrid): the homography where it has >= min_inliers (" +
           std::to_string(RepeatOptions().min_inliers) + ") inliers, the shift_heading vote otherwise",
       Estimator::kChain, {sift}, ShiftHeadingOptions::defaultFeatures()},
  };
}

// The error rates RAS 2017 (Tables 1-2) published for the GRIEF sites [%], by the site folder's name.
nlohmann::ordered_json publishedRates(const std::string& site) {
  const std::vector<std::pair<std::string, std::pair<double, double>>> table = {
      {"SIFT / SIFT", {25.2, 15.8}},        {"upright SIFT / SIFT", {9.7, 10.6}},   {"SURF / SURF", {16.4, 8.8}},
      {"ORB / ORB", {9.7, 20.9}},           {"BRISK / BRISK", {8.5, 3.0}},          {"STAR / SIFT", {0.9, 6.7}},
      {"upright SURF / BRIEF", {2.4, 2.4}}, {"STAR / GRIEF", {0.6, 1.8}},           {"BRISK / GRIEF", {0.3, 1.5}}};
  const bool planetarium = site == "planetarium" || site == "stromovka";
  if (!planetarium && site != "michigan") return nullptr;
  nlohmann::ordered_json rates;
  for (const auto& [name, rate] : table) rates[name] = (planetarium ? rate.first : rate.second) / 100.0;
  return rates;
}

struct Outcome {
  std::optional<double> estimate_px;
  std::string status = "ok";
  double time_ms = 0.0;
  int line_matches = -1;
  int support = -1, runner_up_support = -1;  // the vote's
  int vote_matches = -1;                        // the matches the vote counted (within the vertical limit)
  bool ambiguous = false;
};

// What a method extracted from one image.
struct Extracted {
  std::vector<ImageFeatures> features;  // kHomography: the one feature set
  std::optional<ShiftFeatures> shift;   // kVote
  std::optional<std::vector<VerticalLine>> lines;
  std::optional<LineShiftFeatures> line_points;  // kLineVote
  std::string problem;
  double time_ms = 0.0;
};

// A method's extractor, made once for all its images.
struct Extractors {
  explicit Extractors(const Method& method) {
    if (method.estimator == Estimator::kVote || method.estimator == Estimator::kChain) {
      ShiftHeadingOptions options;
      options.features = method.estimator == Estimator::kChain ? method.vote_features : method.features;
      heading.emplace(options);
    }
    if (method.estimator == Estimator::kHomography || method.estimator == Estimator::kChain) {
      points.emplace(method.features.front());
    }
    if (method.estimator == Estimator::kLineVote) line_shift.emplace();
  }
  std::optional<ShiftHeading> heading;
  std::optional<LineShift> line_shift;
  std::optional<FeatureExtractor> points;
  VerticalLineExtractor lines;
};

Extracted extract(const Method& method, Extractors& extractors, const cv::Mat& image) {
  Extracted e;
  const auto start = Clock::now();
  if (method.estimator == Estimator::kLines) {
    auto lines = extractors.lines.extract(image);
    if (lines) e.lines = std::move(*lines); else e.problem = lines.status().toString();
  }
  if (extractors.line_shift) {
    auto described = extractors.line_shift->describe(image);
    if (described) {
      e.line_points = std::move(*described);
    } else {
      e.problem = described.status().toString();
    }
  }
  if (extractors.heading && e.problem.empty()) {
    auto shift = extractors.heading->describe(image);
    if (shift) e.shift = std::move(*shift); else e.problem = shift.status().toString();
  }
  if (extractors.points && e.problem.empty()) {
    auto features = extractors.points->extract(image);
    if (features) e.features.push_back(std::move(*features)); else e.problem = features.status().toString();
  }
  e.time_ms = msSince(start);
  return e;
}

Outcome measure(const Method& method, const Extractors& extractors, const Extracted& reference,
                const Extracted& current, const cv::Size& size) {
  Outcome outcome;
  if (!reference.problem.empty() || !current.problem.empty()) {
    outcome.status = reference.problem.empty() ? current.problem : reference.problem;
    return outcome;
  }
  const auto start = Clock::now();
  if (method.estimator == Estimator::kLines) {
    const HeadingCorrector corrector(HeadingCorrectionOptions(), LineCamera{static_cast<double>(size.width),
                                                                           0.5 * (size.width - 1)});
    const auto correction = corrector.estimate(*reference.lines, *current.lines);
    if (correction) {
      outcome.estimate_px = correction->mu;
      outcome.line_matches = correction->line_matches;
    } else {
      outcome.status = correction.status().toString();
    }
    outcome.time_ms = msSince(start);
    return outcome;
  }
  if (method.estimator == Estimator::kHomography || method.estimator == Estimator::kChain) {
    const auto registration = registerFeatures(reference.features[0], current.features[0], MatchOptions(),
                                               RobustHomographyOptions(), nullptr);
    const int inliers = registration ? static_cast<int>(registration->homography.inliers.size()) : 0;
    if (registration && (method.estimator == Estimator::kHomography || inliers >= RepeatOptions().min_inliers)) {
      const Eigen::Vector3d centre(0.5 * (size.width - 1), 0.5 * (size.height - 1), 1.0);
      const Eigen::Vector3d mapped = registration->homography.H * centre;
      if (std::abs(mapped.z()) > 1e-12) outcome.estimate_px = mapped.x() / mapped.z() - centre.x();
      else outcome.status = "the homography maps the image centre to infinity";
      outcome.time_ms = msSince(start);
      return outcome;
    }
    if (method.estimator == Estimator::kHomography) {
      outcome.status = registration.status().toString();
      outcome.time_ms = msSince(start);
      return outcome;
    }
  }
  // The benchmark's images have no calibration: the shift at the image's middle.
  const auto fix = method.estimator == Estimator::kLineVote
                       ? extractors.line_shift->measure(*reference.line_points, *current.line_points, 0.5 * size.width)
                       : extractors.heading->measure(*reference.shift, *current.shift, 0.5 * size.width);
  if (fix) {
    outcome.estimate_px = fix->mu;
    outcome.support = fix->shift.support;
    outcome.runner_up_support = fix->shift.runner_up_support;
    outcome.vote_matches = fix->shift.matches;
    outcome.ambiguous = fix->ambiguous;
    if (method.estimator == Estimator::kLineVote) outcome.line_matches = fix->matches;  // line points
  } else {
    outcome.status = fix.status().toString();
  }
  outcome.time_ms = msSince(start);
  return outcome;
}

double median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2), values.end());
  return values[values.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  keepFreedMemoryForReuse();  // as repeat_node: the frame times are the node's
  cli::Arguments args("evaluate_heading_pairs",
                      {{"data", ""}, {"out", ""}, {"methods", ""}, {"max-features", "1600"}, {"tolerance", "35"},
                       {"plots", "1"}},
                      "--data SITE_DIR|LIST_FILE --out DIR\n"
                      "  SITE_DIR: a GRIEF site folder (images/MMLL.png, ground_truth/location_L.txt); LIST_FILE: one pair\n"
                      "  a line, `reference_image current_image true_shift_px` (paths absolute or relative to the list)\n"
                      "  [--methods a,b] (default: all; see the names below) [--max-features 1600] (per image)\n"
                      "  [--tolerance PX] (35: the benchmark's) [--plots 0|1]\n"
                      "  methods: homography, sift_vote, upright_sift_vote, akaze_vote, upright_akaze_vote,\n"
                      "  upright_orb_vote, brief_vote, shift_heading (the repeat's seasonal fix: upright AKAZE + BRIEF),\n"
                      "  upright_akaze_sift_brief_vote, mu_lines (the mu mode's chain), mu_line_vote (vertical lines\n"
                      "  alone, BRIEF along each, one shift vote: mu/line_shift.h), repeat_chain (the repeat's order:\n"
                      "  the homography where it has min_inliers, the shift_heading vote otherwise)");
  args.parse(argc, argv);
  if (args.text("data").empty() || args.text("out").empty()) args.fail("--data and --out are required");
  const int max_features = args.integer("max-features");
  if (max_features < 10) args.fail("--max-features must be >= 10");
  const double tolerance = args.number("tolerance");
  if (!(tolerance > 0.0)) args.fail("--tolerance must be > 0");
  std::vector<Method> methods = allMethods(max_features);
  if (!args.text("methods").empty()) {
    std::vector<Method> chosen;
    std::string list = args.text("methods") + ",";
    for (std::size_t start = 0, end; (end = list.find(',', start)) != std::string::npos; start = end + 1) {
      const std::string name = list.substr(start, end - start);
      const auto it = std::find_if(methods.begin(), methods.end(), [&](const Method& m) { return m.name == name; });
      if (it == methods.end()) args.fail("--methods: unknown method '" + name + "' (see --help)");
      chosen.push_back(*it);
    }
    methods = chosen;
  }
  const auto pairs = eval::readHeadingPairs(args.text("data"));
  if (!pairs) args.fail(pairs.status().message());

  // Every image once, grey; a missing or unreadable image stops the evaluation naming it.
  std::map<std::string, cv::Mat> images;
  for (const auto& pair : *pairs) {
    for (const std::string& path : {pair.reference_image, pair.current_image}) {
      if (images.count(path) != 0) continue;
      const cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
      if (image.empty()) args.fail("cannot read the image '" + path + "'");
      images[path] = image;
    }
  }
  std::cout << pairs->size() << " pairs, " << images.size() << " images from " << args.text("data") << "\n";

  nlohmann::ordered_json doc;
  doc["kind"] = "heading_pairs";
  doc["data"] = args.text("data");
  doc["tolerance_px"] = tolerance;
  doc["max_features"] = max_features;
  // The heading measurement the repeat uses by default (config/repeat_node.yaml, mode hybrid): the
  // plane pose from the registration where it holds, the seasonal shift vote where it does not.
  doc["default_method"] = "repeat_chain";
  fs::path site = fs::path(args.text("data")).lexically_normal();
  if (site.filename().empty()) site = site.parent_path();  // "michigan/"
  doc["published_error_rates"] = publishedRates(site.filename().string());
  nlohmann::ordered_json per_pair = nlohmann::ordered_json::array();
  for (const auto& pair : *pairs) {
    per_pair.push_back({{"reference", pair.reference_image}, {"current", pair.current_image}, {"place", pair.place},
                        {"truth_px", pair.true_shift_px}, {"methods", nlohmann::ordered_json::object()}});
  }
  for (const Method& method : methods) {
    Extractors extractors(method);
    std::map<std::string, Extracted> extracted;
    double extract_ms = 0.0;
    double lines_total = 0.0;
    for (const auto& [path, image] : images) {
      extracted[path] = extract(method, extractors, image);
      extract_ms += extracted[path].time_ms;
      if (extracted[path].lines) lines_total += static_cast<double>(extracted[path].lines->size());
      if (extracted[path].line_points) lines_total += static_cast<double>(extracted[path].line_points->lines.size());
    }
    const double extract_ms_per_image = extract_ms / static_cast<double>(images.size());
    int failures = 0, no_estimate = 0, line_matches_total = 0;
    int ambiguous_right = 0, ambiguous_wrong = 0, wrong_unflagged = 0;  // votes only
    double pair_ms = 0.0;
    std::vector<double> errors;
    for (std::size_t i = 0; i < pairs->size(); ++i) {
      const auto& pair = (*pairs)[i];
      const Outcome outcome = measure(method, extractors, extracted[pair.reference_image],
                                      extracted[pair.current_image], images[pair.reference_image].size());
      pair_ms += outcome.time_ms;
      const bool failed = eval::headingPairFailed(outcome.estimate_px, pair.true_shift_px, tolerance);
      failures += failed ? 1 : 0;
      nlohmann::ordered_json result = {{"status", outcome.status}, {"failed", failed}};
      if (outcome.estimate_px) {
        const double error = *outcome.estimate_px - pair.true_shift_px;
        result["estimate_px"] = *outcome.estimate_px;
        result["error_px"] = error;
        errors.push_back(std::abs(error));
      } else {
        ++no_estimate;
        result["estimate_px"] = nullptr;
        result["error_px"] = nullptr;
      }
      if (outcome.support >= 0) {
        result["support"] = outcome.support;
        result["runner_up_support"] = outcome.runner_up_support;
        result["vote_matches"] = outcome.vote_matches;
        result["ambiguous"] = outcome.ambiguous;
        (failed ? ambiguous_wrong : ambiguous_right) += outcome.ambiguous ? 1 : 0;
        wrong_unflagged += failed && !outcome.ambiguous ? 1 : 0;
      }
      if (outcome.line_matches >= 0) {
        result[method.estimator == Estimator::kLineVote ? "line_point_matches" : "line_matches"] = outcome.line_matches;
        line_matches_total += outcome.line_matches;
      }
      per_pair[i]["methods"][method.name] = result;
    }
    const double n = static_cast<double>(pairs->size());
    nlohmann::ordered_json summary = {{"description", method.description},
                              {"pairs", pairs->size()},
                              {"failures", failures},
                              {"error_rate", failures / n},
                              {"no_estimate", no_estimate},
                              {"median_abs_error_px", errors.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(median(errors))},
                              {"extract_ms_per_image", extract_ms_per_image},
                              {"time_per_pair_ms", 2.0 * extract_ms_per_image + pair_ms / n}};
    if (method.estimator == Estimator::kVote || method.estimator == Estimator::kChain ||
        method.estimator == Estimator::kLineVote) {
      // Estimates flagged ambiguous (ShiftHeadingOptions::ambiguity_ratio) that were right / wrong,
      // and wrong estimates that were not flagged (the ones a repeat would take unquestioned).
      summary["ambiguous_right"] = ambiguous_right;
      summary["ambiguous_wrong"] = ambiguous_wrong;
      summary["wrong_unflagged"] = wrong_unflagged;
    }
    if (method.estimator == Estimator::kLines || method.estimator == Estimator::kLineVote) {
      summary["lines_per_image"] = lines_total / static_cast<double>(images.size());
    }
    if (method.estimator == Estimator::kLines) summary["line_matches_per_pair"] = line_matches_total / n;
    if (method.estimator == Estimator::kLineVote) summary["line_point_matches_per_pair"] = line_matches_total / n;
    doc["methods"][method.name] = summary;
    std::printf("%-20s %5.1f %% failed (%d of %zu; %d without an estimate), %.0f ms per pair\n", method.name.c_str(),
                100.0 * failures / n, failures, pairs->size(), no_estimate, summary["time_per_pair_ms"].get<double>());
    std::fflush(stdout);
  }
  doc["pair_results"] = per_pair;

  std::error_code error;
  fs::create_directories(args.text("out"), error);
  const std::string json_path = (fs::path(args.text("out")) / "heading_pairs.json").string();
  const Status written = writeFileAtomically(json_path, doc.dump(1) + "\n");
  if (!written.isOk()) {
    std::cerr << "evaluate_heading_pairs: " << written.message() << "\n";
    return 1;
  }
  std::cout << "wrote " << json_path << "\n";
  if (args.integer("plots") != 0 && eval::drawPlots(json_path, "evaluate_heading_pairs") != 0) return 1;
  std::cout << "error rate per method (a pair fails beyond " << tolerance << " px or without an estimate):\n";
  for (const Method& method : methods) {
    std::printf("  %-20s %.4f\n", method.name.c_str(), doc["methods"][method.name]["error_rate"].get<double>());
  }
  return 0;
}
