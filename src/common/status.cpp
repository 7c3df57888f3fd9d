#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

const char* toString(StatusCode code) {
  switch (code) {
    case StatusCode::kOk:
      return "OK";
    case StatusCode::kInvalidInput:
      return "INVALID_INPUT";
    case StatusCode::kTooFewPoints:
      return "TOO_FEW_POINTS";
    case StatusCode::kDegenerate:
      return "DEGENERATE";
    case StatusCode::kNotFinite:
      return "NOT_FINITE";
    case StatusCode::kNoConsensus:
      return "NO_CONSENSUS";
  }
  return "UNKNOWN";
}

std::string Status::toString() const {
  if (isOk()) return "OK";
  return std::string(homography_teach_repeat::toString(code_)) + ": " + message_;
}

}  // namespace homography_teach_repeat
