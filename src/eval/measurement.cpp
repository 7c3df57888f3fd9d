#include "homography_teach_repeat/eval/measurement.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace homography_teach_repeat {
namespace eval {

double percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  const double position = std::clamp(fraction, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const auto below = static_cast<std::size_t>(std::floor(position));
  const auto above = std::min(below + 1, values.size() - 1);
  return values[below] + (position - static_cast<double>(below)) * (values[above] - values[below]);
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

nlohmann::json runForJson(const std::string& command) {
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) throw std::runtime_error("cannot run " + command);
  std::string output;
  char buffer[4096];
  while (std::fgets(buffer, sizeof(buffer), pipe) != nullptr) output += buffer;
  if (::pclose(pipe) != 0) throw std::runtime_error("failed: " + command);
  try {
    return nlohmann::json::parse(output);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error("no JSON from " + command + ": " + e.what());
  }
}

std::vector<int> scaleSizes(const cli::Arguments& args, int minimum) {
  std::vector<int> sizes;
  for (const int s : args.indices("sizes", 1000001, {})) {
    if (s < minimum) args.fail("--sizes: each size must be >= " + std::to_string(minimum));
    sizes.push_back(s);
  }
  if (sizes.empty()) args.fail("--sizes: at least one size");
  return sizes;
}

}  // namespace eval
}  // namespace homography_teach_repeat
