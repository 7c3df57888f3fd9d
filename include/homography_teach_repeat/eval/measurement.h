// Small helpers the evaluation programs share: percentiles of their measurements, elapsed time, and
// a measurement run in a fresh process (whose peak resident memory is then its own).
#pragma once

#include <nlohmann/json.hpp>

#include <chrono>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"

namespace homography_teach_repeat {
namespace eval {

// The `fraction` quantile (0.5: the median) of `values`, linearly interpolated between ranks; NaN
// for no values.
double percentile(std::vector<double> values, double fraction);

// Seconds since `start` on the steady clock.
double secondsSince(std::chrono::steady_clock::time_point start);

// Runs `command` through the shell and parses what it prints as one JSON document. Throws
// std::runtime_error naming the command when it cannot run, exits non-zero or prints no JSON.
nlohmann::json runForJson(const std::string& command);

// The map sizes of a scale evaluation: the comma-separated `--sizes`, each at least `minimum` (the
// program fails with a message otherwise, or when there is none).
std::vector<int> scaleSizes(const cli::Arguments& args, int minimum);

}  // namespace eval
}  // namespace homography_teach_repeat
