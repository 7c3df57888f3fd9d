#include "homography_teach_repeat/features/feature_matcher.h"

#include <opencv2/features2d.hpp>

#include <algorithm>
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

// Descriptor rows as zero-padded 64-bit words (the padding XORs to zero in a Hamming distance).
std::vector<std::uint64_t> toWords(const cv::Mat& descriptors, int words) {
  std::vector<std::uint64_t> out(static_cast<std::size_t>(descriptors.rows) * static_cast<std::size_t>(words), 0);
  for (int r = 0; r < descriptors.rows; ++r) {
    std::memcpy(out.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(words),
                descriptors.ptr<std::uint8_t>(r), static_cast<std::size_t>(descriptors.cols));
  }
  return out;
}

// Hamming distances of one reference row to every current row. cv::batchDistance calls
// cv::normHamming once per pair (~12 ns for a 32-byte ORB descriptor with its dispatch and tracing
// overhead); this loop uses the POPCNT instruction where the CPU has it (x86-64 builds are not
// compiled for it by default, and a plain __builtin_popcountll becomes a library call), chosen
// once at load time.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("popcnt", "default")))
#endif
void hammingRow(const std::uint64_t* x, const std::uint64_t* b, int rows_b, int words, float* out) {
  for (int j = 0; j < rows_b; ++j) {
    const std::uint64_t* y = b + static_cast<std::ptrdiff_t>(j) * words;
    int d = 0;
    for (int w = 0; w < words; ++w) d += __builtin_popcountll(x[w] ^ y[w]);
    out[j] = static_cast<float>(d);
  }
}

// Lowe's ratio test on the two nearest neighbours of each reference row, and the mutual check
// against the nearest reference row of each current column. `distancesOfRow(i, out)` fills the
// distances of reference row i to all `cols` current rows. Blocks of rows run in parallel
// (cv::parallel_for_), each with its own column minima, merged in row order so that ties resolve
// as in a sequential scan (the first row wins).
template <class DistancesOfRow>
std::vector<cv::DMatch> ratioAndMutualMatches(int rows, int cols, const DistancesOfRow& distancesOfRow,
                                              const MatchOptions& options) {
  std::vector<int> row_best(static_cast<std::size_t>(rows), -1);
  std::vector<float> row_best_distance(static_cast<std::size_t>(rows));
  std::vector<float> row_second_distance(static_cast<std::size_t>(rows));
  const int blocks = std::max(1, std::min(rows, 4 * std::max(1, cv::getNumThreads())));
  std::vector<std::vector<int>> block_column_best(static_cast<std::size_t>(blocks));
  std::vector<std::vector<float>> block_column_distance(static_cast<std::size_t>(blocks));
  cv::parallel_for_(cv::Range(0, blocks), [&](const cv::Range& range) {
    std::vector<float> row(static_cast<std::size_t>(cols));
    for (int block = range.start; block < range.end; ++block) {
      auto& column_best = block_column_best[static_cast<std::size_t>(block)];
      auto& column_distance = block_column_distance[static_cast<std::size_t>(block)];
      column_best.assign(static_cast<std::size_t>(cols), -1);
      column_distance.assign(static_cast<std::size_t>(cols), std::numeric_limits<float>::infinity());
      const int first = static_cast<int>(static_cast<long>(rows) * block / blocks);
      const int last = static_cast<int>(static_cast<long>(rows) * (block + 1) / blocks);
      for (int i = first; i < last; ++i) {
        distancesOfRow(i, row.data());
        float best = std::numeric_limits<float>::infinity(), second = best;
        int best_index = -1;
        for (int j = 0; j < cols; ++j) {
          const float d = row[static_cast<std::size_t>(j)];
          if (d < best) {
            second = best;
            best = d;
            best_index = j;
          } else if (d < second) {
            second = d;
          }
          if (d < column_distance[static_cast<std::size_t>(j)]) {
            column_distance[static_cast<std::size_t>(j)] = d;
            column_best[static_cast<std::size_t>(j)] = i;
          }
        }
        row_best[static_cast<std::size_t>(i)] = best_index;
        row_best_distance[static_cast<std::size_t>(i)] = best;
        row_second_distance[static_cast<std::size_t>(i)] = second;
      }
    }
  });
  std::vector<int> column_best = block_column_best[0];
  std::vector<float> column_distance = block_column_distance[0];
  for (std::size_t block = 1; block < block_column_best.size(); ++block) {
    for (std::size_t j = 0; j < column_best.size(); ++j) {
      if (block_column_distance[block][j] < column_distance[j]) {
        column_distance[j] = block_column_distance[block][j];
        column_best[j] = block_column_best[block][j];
      }
    }
  }
  std::vector<cv::DMatch> result;
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
  // One pass of distance computations (the expensive part): the forward two nearest neighbours
  // per row and the backward nearest neighbour per column come from the same distances. Two
  // brute-force passes (knnMatch + match) cost twice as much; see bench_repeat_localizer
  // (BM_MatchOrb1500_*) for this against OpenCV's brute force.
  const cv::Mat& ref = reference.descriptors;
  const cv::Mat& cur = current.descriptors;
  if (hasBinaryDescriptor(reference.type)) {
    const int words = (ref.cols + 7) / 8;
    const std::vector<std::uint64_t> ref_words = toWords(ref, words), cur_words = toWords(cur, words);
    return ratioAndMutualMatches(
        ref.rows, cur.rows,
        [&](int i, float* out) {
          hammingRow(ref_words.data() + static_cast<std::ptrdiff_t>(i) * words, cur_words.data(), cur.rows,
                     words, out);
        },
        options);
  }
  if (ref.depth() != CV_32F) return Status(StatusCode::kInvalidInput, "float descriptors must be CV_32F");
  try {
    return ratioAndMutualMatches(
        ref.rows, cur.rows,
        [&](int i, float* out) {
          cv::Mat row(1, cur.rows, CV_32F, out);
          cv::batchDistance(ref.row(i), cur, row, CV_32F, cv::noArray(), cv::NORM_L2, 0);
        },
        options);
  } catch (const cv::Exception& e) {
    return Status(StatusCode::kInvalidInput, std::string("descriptor matching: ") + e.what());
  }
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
