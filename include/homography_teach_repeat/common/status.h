// Explicit success/failure for every estimator of the core library.
//
// Estimators never return a pose, a homography or a covariance from a failed computation: they
// return an Expected<T> whose status says why. Construction of configuration objects (cameras,
// parameters) with invalid values throws std::invalid_argument instead, because that is a
// programming or configuration error that must stop start-up loudly.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace homography_teach_repeat {

enum class StatusCode {
  kOk = 0,
  kInvalidInput,   // malformed input: empty image, wrong size, NaN, wrong encoding
  kTooFewPoints,   // fewer matches/points than the method needs
  kDegenerate,     // geometry without a unique solution (collinear points, singular plane)
  kNotFinite,      // a computation produced NaN/Inf
  kNoConsensus,    // robust estimation found no model with enough support
};

const char* toString(StatusCode code);

class Status {
 public:
  Status() = default;  // OK
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status ok() { return Status(); }

  bool isOk() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // "<code>: <message>", for logs and diagnostics.
  std::string toString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

// A value or the status explaining why there is none.
template <typename T>
class Expected {
 public:
  Expected(T value) : value_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
  Expected(Status status) : status_(std::move(status)) {  // NOLINT(google-explicit-constructor)
    if (status_.isOk()) {
      throw std::logic_error("Expected<T> built from an OK status without a value");
    }
  }

  bool isOk() const { return value_.has_value(); }
  explicit operator bool() const { return isOk(); }
  const Status& status() const { return status_; }

  const T& value() const {
    if (!value_) throw std::logic_error("Expected<T>::value() on a failure: " + status_.toString());
    return *value_;
  }
  T& value() {
    if (!value_) throw std::logic_error("Expected<T>::value() on a failure: " + status_.toString());
    return *value_;
  }
  const T& operator*() const { return value(); }
  const T* operator->() const { return &value(); }
  T& operator*() { return value(); }
  T* operator->() { return &value(); }

 private:
  std::optional<T> value_;
  Status status_;
};

}  // namespace homography_teach_repeat
