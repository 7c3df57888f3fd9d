#include "homography_teach_repeat/feature_matcher.h"

#include <opencv2/features2d.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

namespace homography_teach_repeat {

void MatchOptions::validate() const {
  if (!(ratio > 0.0 && ratio <= 1.0)) throw std::invalid_argument("ratio must be in (0, 1]");
}

namespace {

// Hamming distances between the rows of two CV_8U descriptor matrices, as CV_32F (exact: at most
// 8 * cols). The rows are copied into zero-padded 64-bit words (the padding XORs to zero).
std::vector<std::uint64_t> toWords(const cv::Mat& descriptors, int words) {
  std::vector<std::uint64_t> out(static_cast<std::size_t>(descriptors.rows) * static_cast<std::size_t>(words), 0);
  for (int r = 0; r < descriptors.rows; ++r) {
    std::memcpy(out.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(words), descriptors.ptr<std::uint8_t>(r),
                static_cast<std::size_t>(descriptors.cols));
  }
  return out;
}

// The POPCNT instruction where the CPU has it (x86-64 builds are not compiled for it by default:
// a plain __builtin_popcountll becomes a library call), chosen once at load time.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("popcnt", "default")))
#endif
void hammingRows(const std::uint64_t* a, int rows_a, const std::uint64_t* b, int rows_b, int words,
                 float* out) {
  for (int i = 0; i < rows_a; ++i) {
    const std::uint64_t* x = a + static_cast<std::ptrdiff_t>(i) * words;
    float* row = out + static_cast<std::ptrdiff_t>(i) * rows_b;
    for (int j = 0; j < rows_b; ++j) {
      const std::uint64_t* y = b + static_cast<std::ptrdiff_t>(j) * words;
      int d = 0;
      for (int w = 0; w < words; ++w) d += __builtin_popcountll(x[w] ^ y[w]);
      row[j] = static_cast<float>(d);
    }
  }
}

cv::Mat hammingDistanceMatrix(const cv::Mat& a, const cv::Mat& b) {
  const int words = (a.cols + 7) / 8;
  const std::vector<std::uint64_t> wa = toWords(a, words), wb = toWords(b, words);
  cv::Mat distances(a.rows, b.rows, CV_32F);
  hammingRows(wa.data(), a.rows, wb.data(), b.rows, words, distances.ptr<float>());
  return distances;
}

// Lowe's ratio test on the two nearest neighbours of each row, and the mutual check against the
// nearest row of each column, from one distance matrix (rows: reference, columns: current).
std::vector<cv::DMatch> matchFromDistances(const cv::Mat& distances, const MatchOptions& options) {
  std::vector<cv::DMatch> result;
  const int rows = distances.rows;
  const int cols = distances.cols;
  std::vector<int> column_best(static_cast<std::size_t>(cols), -1);
  std::vector<float> column_best_distance(static_cast<std::size_t>(cols),
                                          std::numeric_limits<float>::infinity());
  std::vector<int> row_best(static_cast<std::size_t>(rows), -1);
  std::vector<float> row_best_distance(static_cast<std::size_t>(rows)), row_second_distance(static_cast<std::size_t>(rows));
  for (int i = 0; i < rows; ++i) {
    const float* row = distances.ptr<float>(i);
    float best = std::numeric_limits<float>::infinity(), second = best;
    int best_index = -1;
    for (int j = 0; j < cols; ++j) {
      const float d = row[j];
      if (d < best) {
        second = best;
        best = d;
        best_index = j;
      } else if (d < second) {
        second = d;
      }
      if (d < column_best_distance[static_cast<std::size_t>(j)]) {
        column_best_distance[static_cast<std::size_t>(j)] = d;
        column_best[static_cast<std::size_t>(j)] = i;
      }
    }
    row_best[static_cast<std::size_t>(i)] = best_index;
    row_best_distance[static_cast<std::size_t>(i)] = best;
    row_second_distance[static_cast<std::size_t>(i)] = second;
  }
  for (int i = 0; i < rows; ++i) {
    const int j = row_best[static_cast<std::size_t>(i)];
    if (j < 0) continue;
    const float best = row_best_distance[static_cast<std::size_t>(i)];
    if (!(best < options.ratio * row_second_distance[static_cast<std::size_t>(i)])) continue;
    if (options.mutual && column_best[static_cast<std::size_t>(j)] != i) continue;
    result.emplace_back(i, j, best);
  }
  return result;
}

}  // namespace

Expected<std::vector<cv::DMatch>> matchFeatures(const ImageFeatures& reference,
                                                const ImageFeatures& current,
                                                const MatchOptions& options) {
  options.validate();
  if (reference.type != current.type) {
    return Status(StatusCode::kInvalidInput, "cannot match " + toString(reference.type) +
                                                 " features against " + toString(current.type));
  }
  std::vector<cv::DMatch> result;
  if (reference.keypoints.size() < 2 || current.keypoints.size() < 2) return result;
  if (reference.descriptors.type() != current.descriptors.type() ||
      reference.descriptors.cols != current.descriptors.cols) {
    return Status(StatusCode::kInvalidInput, "descriptor layouts differ");
  }
  if (hasBinaryDescriptor(reference.type) && reference.descriptors.depth() != CV_8U) {
    return Status(StatusCode::kInvalidInput, "binary descriptors must be 8-bit");
  }
  // One pass of distance computations (the expensive part): the full distance matrix, then the
  // forward two nearest neighbours per row and the backward nearest neighbour per column are read
  // from it. Two brute-force passes (knnMatch + match) cost twice as much (ORB 1500 x 1500:
  // 36 -> 20 ms measured under load).
  cv::Mat distances;
  if (hasBinaryDescriptor(reference.type)) {
    // cv::batchDistance calls cv::normHamming once per pair (~12 ns for a 32-byte ORB descriptor
    // with its dispatch and tracing overhead); a popcount loop over 64-bit words is several
    // times faster (bench_repeat_localizer: BM_MatchOrb1500_*).
    distances = hammingDistanceMatrix(reference.descriptors, current.descriptors);
  } else {
    try {
      cv::batchDistance(reference.descriptors, current.descriptors, distances, CV_32F, cv::noArray(),
                        cv::NORM_L2, 0);
    } catch (const cv::Exception& e) {
      return Status(StatusCode::kInvalidInput, std::string("descriptor matching: ") + e.what());
    }
  }
  return matchFromDistances(distances, options);
}

PointMatches toPointMatches(const ImageFeatures& reference, const ImageFeatures& current,
                            const std::vector<cv::DMatch>& matches) {
  PointMatches out;
  out.reserve(matches.size());
  for (const auto& m : matches) {
    const cv::Point2f& a = reference.keypoints[static_cast<std::size_t>(m.queryIdx)].pt;
    const cv::Point2f& b = current.keypoints[static_cast<std::size_t>(m.trainIdx)].pt;
    out.push_back({Eigen::Vector2d(a.x, a.y), Eigen::Vector2d(b.x, b.y)});
  }
  return out;
}

}  // namespace homography_teach_repeat
