// The place index of a map (docs/map_format.md, "Finding the place without a hint"): proposes the
// keyframes an image most likely shows, so that relocalization checks the geometry of a few
// candidates instead of every keyframe of a map of thousands.
//
// Each keyframe's local descriptors become one global vector: a bag of visual words (a vocabulary
// of k-means centres trained on the map's own descriptors; each descriptor counts for its nearest
// word, found exactly), weighted by inverse document frequency, square-rooted (a repeated texture
// does not dominate) and L2-normalised (optionally reduced by PCA and normalised again). The
// nearest keyframes are found with OpenCV's FLANN (a hierarchical k-means tree), so a query does
// not grow linearly with the map. Binary descriptors (ORB, AKAZE, BRIEF) are used as vectors of
// their bits.
#pragma once

#include <opencv2/core.hpp>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct PlaceIndexOptions {
  int vocabulary_words = 256;         // k-means centres (fewer when there are fewer descriptors)
  int training_descriptors = 20000;   // at most this many, sampled evenly over the keyframes, train them
  int kmeans_iterations = 8;
  int dimensions = 256;               // of the global vector: fewer than the words reduces it by PCA
  int search_checks = 2048;           // FLANN leaves visited per search: recall against time
  unsigned seed = 12345;              // of k-means: the same map gives the same index
};

struct PlaceCandidate {
  std::size_t place = 0;    // the keyframe's position in the list the index was built from
  double similarity = 0.0;  // cosine of the two global vectors, in [-1, 1]
};

class PlaceIndex {
 public:
  // One entry per keyframe: its descriptors (rows; CV_32F, or CV_8U binary), all of one type and
  // width. A keyframe without descriptors is kept (it is never proposed). kInvalidInput for no
  // keyframe, mixed types or widths, or fewer than 2 descriptors in all; kNotFinite for a non-finite value.
  static Expected<PlaceIndex> build(const std::vector<cv::Mat>& place_descriptors,
                                    const PlaceIndexOptions& options = {});

  // Up to `count` keyframes, most similar first. Empty for an image without descriptors;
  // kInvalidInput for descriptors of another type or width than the index's.
  Expected<std::vector<PlaceCandidate>> query(const cv::Mat& descriptors, int count) const;

  std::size_t size() const;
  int words() const;
  int dimensions() const;

  // What each keyframe is to the caller (a map keyframe, "route:index"), saved with the index;
  // empty or one per keyframe. kInvalidInput for another count.
  Status setLabels(std::vector<std::string> labels);
  const std::vector<std::string>& labels() const;

  // Written atomically (OpenCV FileStorage, YAML); load checks the content and names the file.
  Status save(const std::string& path) const;
  static Expected<PlaceIndex> load(const std::string& path, const PlaceIndexOptions& options = {});

  PlaceIndex(PlaceIndex&&) noexcept;
  PlaceIndex& operator=(PlaceIndex&&) noexcept;
  ~PlaceIndex();

 private:
  PlaceIndex();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace homography_teach_repeat
