// Shared helpers of the libFuzzer targets (test/fuzz/CMakeLists.txt, scripts/fuzz).
#pragma once

#include <fuzzer/FuzzedDataProvider.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace htr_fuzz {

// A directory of this process for the files the loaders read (under TMPDIR, else /tmp).
inline const std::string& scratchDirectory() {
  static const std::string directory = [] {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base && *base ? base : "/tmp") + "/htr_fuzz_XXXXXX";
    if (!::mkdtemp(pattern.data())) throw std::runtime_error("cannot create a scratch directory under " + pattern);
    return pattern;
  }();
  return directory;
}

inline void writeFile(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) throw std::runtime_error("cannot write " + path);
}

inline std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Any double, special values included (ConsumeFloatingPoint alone gives only finite ones).
inline double anyDouble(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange<int>(0, 9)) {
    case 0: return std::numeric_limits<double>::quiet_NaN();
    case 1: return std::numeric_limits<double>::infinity();
    case 2: return -std::numeric_limits<double>::infinity();
    case 3: return 0.0;
    case 4: return std::numeric_limits<double>::denorm_min();
    case 5: return std::numeric_limits<double>::max();
    case 6: return in.ConsumeFloatingPointInRange<double>(-1.0, 1.0);
    case 7: return in.ConsumeFloatingPointInRange<double>(-1e4, 1e4);
    default: return in.ConsumeFloatingPoint<double>();
  }
}

inline int anyInt(FuzzedDataProvider& in) {
  return in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(-4, 4000) : in.ConsumeIntegral<int>();
}

}  // namespace htr_fuzz
