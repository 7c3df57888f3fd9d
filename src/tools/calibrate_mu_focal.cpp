// calibrate_mu_focal: the one calibration parameter of the μ heading correction (paper 002
// §4.1): f such that μ = f tan θ, fitted from images taken at known yaw angles (e.g. on a
// rotating head, or the robot turning in place against a reference) or from (θ, μ) pairs.
//
//   rosrun homography_teach_repeat calibrate_mu_focal --list FILE [--cx X] [--json F]
//   rosrun homography_teach_repeat calibrate_mu_focal --pairs FILE [--json F]
//
// --list FILE: one image per line, "PATH YAW_DEG"; the first line is the reference (its yaw is
//   subtracted from the others). Yaw is counter-clockwise seen from above (turning left is
//   positive), the sign of PlanarPose::theta. Images: grey or colour, undistorted, same size.
//   --cx: principal point x [px], default (width − 1)/2.
// --pairs FILE: one sample per line, "YAW_DEG MU_PX".
// Prints f [px], the RMS residual of μ and each sample; exit 2 on bad input.
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/mu/heading_1d.h"
#include "homography_teach_repeat/mu/heading_correction.h"
#include "homography_teach_repeat/features/vertical_lines.h"

using namespace homography_teach_repeat;

namespace {

constexpr double kDegToRad = M_PI / 180.0;

std::vector<std::pair<std::string, double>> readPairsFile(const std::string& path,
                                                          const cli::Arguments& args) {
  std::ifstream in(path);
  if (!in) args.fail("cannot open '" + path + "'");
  std::vector<std::pair<std::string, double>> rows;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string first;
    double second = 0.0;
    if (!(fields >> first >> second) || !std::isfinite(second)) {
      args.fail(path + ":" + std::to_string(number) + ": expected two fields, got '" + line + "'");
    }
    rows.emplace_back(first, second);
  }
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  cli::Arguments args("calibrate_mu_focal",
                       {{"list", ""}, {"pairs", ""}, {"cx", ""}, {"json", ""}},
                       "(--list FILE [--cx X] | --pairs FILE) [--json F]");
  args.parse(argc, argv);
  if (args.text("list").empty() == args.text("pairs").empty()) {
    args.fail("give exactly one of --list and --pairs (see --help)");
  }
  std::vector<std::pair<double, double>> samples;  // (θ [rad], μ [px])
  nlohmann::json per_sample = nlohmann::json::array();
  if (!args.text("pairs").empty()) {
    for (const auto& [yaw, mu] : readPairsFile(args.text("pairs"), args)) {
      double yaw_deg = 0.0;
      try {
        yaw_deg = std::stod(yaw);
      } catch (const std::exception&) {
        args.fail("'" + yaw + "' is not a yaw angle in degrees");
      }
      samples.emplace_back(yaw_deg * kDegToRad, mu);
      per_sample.push_back({{"yaw_deg", yaw_deg}, {"mu_px", mu}});
    }
  } else {
    const auto rows = readPairsFile(args.text("list"), args);
    if (rows.size() < 2) args.fail("--list needs a reference and at least one more image");
    VerticalLineExtractor extractor;
    std::vector<std::vector<VerticalLine>> lines;
    cv::Size size;
    for (const auto& [path, yaw] : rows) {
      const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
      if (image.empty()) args.fail("cannot read image '" + path + "'");
      if (size.width == 0) size = image.size();
      if (image.size() != size) args.fail("'" + path + "' differs in size from the reference");
      const auto extracted = extractor.extract(image);
      if (!extracted) args.fail(path + ": " + extracted.status().toString());
      lines.push_back(*extracted);
    }
    const double cx = args.text("cx").empty() ? 0.5 * (size.width - 1) : args.number("cx");
    // f only scales θ inside the corrector; μ, which is what is fitted, does not depend on it.
    const HeadingCorrector corrector(HeadingCorrectionOptions(), LineCamera{1.0, cx});
    for (std::size_t k = 1; k < rows.size(); ++k) {
      const auto correction = corrector.estimate(lines.front(), lines[k]);
      const double yaw_deg = rows[k].second - rows.front().second;
      if (!correction) {
        std::cerr << "calibrate_mu_focal: skipping '" << rows[k].first
                  << "': " << correction.status().toString() << "\n";
        per_sample.push_back({{"image", rows[k].first}, {"status", correction.status().toString()}});
        continue;
      }
      samples.emplace_back(yaw_deg * kDegToRad, correction->mu);
      per_sample.push_back({{"image", rows[k].first}, {"yaw_deg", yaw_deg},
                            {"mu_px", correction->mu}, {"inliers", correction->inliers}});
    }
  }
  const auto fit = fitFocalFromMu(samples);
  if (!fit) args.fail("fit: " + fit.status().toString());
  std::cout << std::fixed << std::setprecision(2) << "f = " << fit->f << " px from "
            << fit->samples << " samples, RMS residual of mu " << fit->rms_residual_px << " px\n";
  for (const auto& s : per_sample) std::cout << "  " << s.dump() << "\n";
  args.writeJson({{"f_px", fit->f}, {"rms_residual_px", fit->rms_residual_px},
                  {"samples", per_sample}});
  return 0;
}
