// Numbers in messages: what the user reads in logs, diagnostics and reasons.
#pragma once

#include <sstream>
#include <string>

namespace homography_teach_repeat {

// `value` with `digits` digits after the point ("0.30"), as std::fixed prints it.
inline std::string formatFixed(double value, int digits) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << value;
  return out.str();
}

}  // namespace homography_teach_repeat
