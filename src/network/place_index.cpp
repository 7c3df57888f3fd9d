#include "homography_teach_repeat/network/place_index.h"

#include <opencv2/flann.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "homography_teach_repeat/common/atomic_file.h"

namespace homography_teach_repeat {
namespace {

Status invalid(const std::string& message) { return Status(StatusCode::kInvalidInput, message); }

// Descriptors as CV_32F rows: float descriptors as they are, binary ones bit by bit (0 or 1).
cv::Mat asFloatRows(const cv::Mat& descriptors, bool binary) {
  if (!binary) {
    cv::Mat rows;
    descriptors.convertTo(rows, CV_32F);
    return rows;
  }
  cv::Mat bits(descriptors.rows, descriptors.cols * 8, CV_32F);
  for (int r = 0; r < descriptors.rows; ++r) {
    const auto* in = descriptors.ptr<std::uint8_t>(r);
    auto* out = bits.ptr<float>(r);
    for (int c = 0; c < descriptors.cols; ++c) {
      for (int b = 0; b < 8; ++b) out[c * 8 + b] = static_cast<float>((in[c] >> b) & 1);
    }
  }
  return bits;
}

// The keyframes' global vectors under FLANN's hierarchical k-means tree (branching 16): in 256
// dimensions it finds the revisited place among 10 candidates about as often as an exhaustive
// search, where randomised k-d trees needed about every keyframe checked (measurements:
// docs/evaluation.md, "Place index"). FLANN seeds its tree from std::rand: seeded
// here so that the same keyframes give the same tree, and a loaded index proposes what the built
// one did. Below 64 keyframes an exact search.
std::unique_ptr<cv::flann::Index> makePlaceSearch(const cv::Mat& rows) {
  if (rows.rows == 0) return nullptr;
  std::srand(12345);
  if (rows.rows < 64) return std::make_unique<cv::flann::Index>(rows, cv::flann::LinearIndexParams());
  return std::make_unique<cv::flann::Index>(rows, cv::flann::KMeansIndexParams(16, 11));
}

}  // namespace

struct PlaceIndex::Impl {
  bool binary = false;
  int descriptor_cols = 0;       // as given (bytes for binary)
  cv::Mat vocabulary;            // words x descriptor dimensions, CV_32F
  cv::Mat idf;                   // 1 x words
  cv::Mat pca_mean;              // 1 x words (empty: no projection)
  cv::Mat pca_basis;             // dimensions x words
  cv::Mat places;                // keyframes x dimensions, unit rows (zero rows for empty keyframes)
  std::vector<int> indexed;      // rows of `places` that are in `place_search` (non-empty keyframes)
  cv::Mat indexed_places;
  std::vector<std::string> labels;  // empty or one per row of `places`
  std::unique_ptr<cv::flann::Index> place_search;
  int checks = 64;

  // The nearest word of each row, exactly (a vocabulary of a few hundred words is searched
  // faster by brute force than a tree would save, and the result does not depend on a tree).
  cv::Mat nearestWords(const cv::Mat& rows) const {
    cv::Mat distances;
    cv::Mat nearest;
    cv::batchDistance(rows, vocabulary, distances, CV_32F, nearest, cv::NORM_L2SQR, 1);
    return nearest;
  }

  // Square-rooted idf-weighted histogram of the words of an image's descriptors (nearestWords),
  // L2-normalised (zero for no descriptors).
  cv::Mat histogram(const cv::Mat& nearest) const {
    cv::Mat h = cv::Mat::zeros(1, vocabulary.rows, CV_32F);
    if (nearest.rows == 0) return h;
    for (int r = 0; r < nearest.rows; ++r) h.at<float>(0, nearest.at<int>(r, 0)) += 1.0f;
    cv::sqrt(h / static_cast<float>(nearest.rows), h);
    h = h.mul(idf);
    const double norm = cv::norm(h);
    if (norm > 0.0) h /= norm;
    return h;
  }

  // The histogram reduced by the PCA (when there is one) and L2-normalised (zero stays zero).
  cv::Mat project(const cv::Mat& h) const {
    if (pca_basis.empty()) return h.clone();
    if (cv::norm(h) == 0.0) return cv::Mat::zeros(1, pca_basis.rows, CV_32F);
    cv::Mat projected = (h - pca_mean) * pca_basis.t();
    const double norm = cv::norm(projected);
    if (norm > 0.0) projected /= norm;
    return projected;
  }

  void indexPlaces() {
    indexed.clear();
    indexed_places.release();
    for (int r = 0; r < places.rows; ++r) {
      if (cv::norm(places.row(r)) > 0.0) {
        indexed.push_back(r);
        indexed_places.push_back(places.row(r));
      }
    }
    place_search = makePlaceSearch(indexed_places);
  }
};

PlaceIndex::PlaceIndex() : impl_(std::make_unique<Impl>()) {}
PlaceIndex::~PlaceIndex() = default;
PlaceIndex::PlaceIndex(PlaceIndex&&) noexcept = default;
PlaceIndex& PlaceIndex::operator=(PlaceIndex&&) noexcept = default;

std::size_t PlaceIndex::size() const { return static_cast<std::size_t>(impl_->places.rows); }
int PlaceIndex::words() const { return impl_->vocabulary.rows; }
int PlaceIndex::dimensions() const { return impl_->places.cols; }

Expected<PlaceIndex> PlaceIndex::build(const std::vector<cv::Mat>& place_descriptors, const PlaceIndexOptions& options) {
  if (place_descriptors.empty()) return invalid("place index: no keyframe");
  if (options.vocabulary_words < 2 || options.training_descriptors < 2 || options.dimensions < 1 ||
      options.kmeans_iterations < 1 || options.search_checks < 1) {
    return invalid("place index: words and training descriptors must be >= 2, dimensions, iterations and checks >= 1");
  }
  PlaceIndex index;
  Impl& g = *index.impl_;
  g.checks = options.search_checks;
  int type = -1;
  std::size_t total = 0;
  for (std::size_t p = 0; p < place_descriptors.size(); ++p) {
    const cv::Mat& d = place_descriptors[p];
    if (d.empty()) continue;
    if (d.type() != CV_32F && d.type() != CV_8U) {
      return invalid("place index: keyframe " + std::to_string(p) + " has descriptors that are neither CV_32F nor CV_8U");
    }
    if (type < 0) {
      type = d.type();
      g.descriptor_cols = d.cols;
    } else if (d.type() != type || d.cols != g.descriptor_cols) {
      return invalid("place index: keyframe " + std::to_string(p) + " has descriptors of another type or width");
    }
    if (d.type() == CV_32F && !cv::checkRange(d)) {
      return Status(StatusCode::kNotFinite, "place index: keyframe " + std::to_string(p) + " has a non-finite descriptor");
    }
    total += static_cast<std::size_t>(d.rows);
  }
  if (total < 2) return invalid("place index: the keyframes hold fewer than 2 descriptors in all");
  g.binary = type == CV_8U;

  // Train the vocabulary on descriptors sampled evenly over all keyframes.
  const std::size_t stride = std::max<std::size_t>(1, total / static_cast<std::size_t>(options.training_descriptors));
  cv::Mat sample;
  std::size_t counter = 0;
  for (const cv::Mat& d : place_descriptors) {
    for (int r = 0; r < d.rows; ++r, ++counter) {
      if (counter % stride == 0) sample.push_back(asFloatRows(d.row(r), g.binary));
    }
  }
  const int words = std::min(options.vocabulary_words, sample.rows);
  cv::Mat labels;
  cv::RNG& rng = cv::theRNG();
  const cv::RNG saved = rng;
  rng.state = options.seed;
  cv::kmeans(sample, words, labels, cv::TermCriteria(cv::TermCriteria::MAX_ITER, options.kmeans_iterations, 0.0), 1,
             cv::KMEANS_PP_CENTERS, g.vocabulary);
  rng = saved;

  // Each keyframe's words (once: only they are kept, not the descriptors as floats), then the
  // inverse document frequency of each word over the keyframes.
  g.idf = cv::Mat::ones(1, words, CV_32F);
  std::vector<cv::Mat> place_words(place_descriptors.size());
  std::vector<int> documents(static_cast<std::size_t>(words), 0);
  int non_empty = 0;
  for (std::size_t p = 0; p < place_descriptors.size(); ++p) {
    if (place_descriptors[p].empty()) continue;
    ++non_empty;
    place_words[p] = g.nearestWords(asFloatRows(place_descriptors[p], g.binary));
    const cv::Mat& nearest = place_words[p];
    std::vector<bool> seen(static_cast<std::size_t>(words), false);
    for (int r = 0; r < nearest.rows; ++r) seen[static_cast<std::size_t>(nearest.at<int>(r, 0))] = true;
    for (int w = 0; w < words; ++w) documents[static_cast<std::size_t>(w)] += seen[static_cast<std::size_t>(w)] ? 1 : 0;
  }
  for (int w = 0; w < words; ++w) {
    g.idf.at<float>(0, w) = static_cast<float>(std::log((1.0 + non_empty) / (1.0 + documents[static_cast<std::size_t>(w)])) + 1.0);
  }
  cv::Mat histograms = cv::Mat::zeros(static_cast<int>(place_descriptors.size()), words, CV_32F);
  for (std::size_t p = 0; p < place_words.size(); ++p) {
    g.histogram(place_words[p]).copyTo(histograms.row(static_cast<int>(p)));
  }

  // PCA over the non-empty keyframes' histograms, when there are more of them than dimensions.
  const int dimensions = std::min(options.dimensions, words);
  cv::Mat non_empty_histograms;
  for (int p = 0; p < histograms.rows; ++p) {
    if (cv::norm(histograms.row(p)) > 0.0) non_empty_histograms.push_back(histograms.row(p));
  }
  if (non_empty_histograms.rows > dimensions && dimensions < words) {
    const cv::PCA pca(non_empty_histograms, cv::noArray(), cv::PCA::DATA_AS_ROW, dimensions);
    g.pca_mean = pca.mean.clone();
    g.pca_basis = pca.eigenvectors.clone();
  }
  g.places = cv::Mat::zeros(histograms.rows, g.pca_basis.empty() ? words : g.pca_basis.rows, CV_32F);
  for (int p = 0; p < histograms.rows; ++p) g.project(histograms.row(p)).copyTo(g.places.row(p));
  g.indexPlaces();
  return index;
}

Expected<std::vector<PlaceCandidate>> PlaceIndex::query(const cv::Mat& descriptors, int count) const {
  const Impl& g = *impl_;
  std::vector<PlaceCandidate> candidates;
  if (descriptors.empty() || count <= 0 || g.indexed.empty()) return candidates;
  if (descriptors.type() != (g.binary ? CV_8U : CV_32F) || descriptors.cols != g.descriptor_cols) {
    return invalid("place index: the image's descriptors are not of the map's type and width");
  }
  if (!g.binary && !cv::checkRange(descriptors)) return Status(StatusCode::kNotFinite, "place index: non-finite descriptor");
  const cv::Mat v = g.project(g.histogram(g.nearestWords(asFloatRows(descriptors, g.binary))));
  if (cv::norm(v) == 0.0) return candidates;
  const int k = std::min<int>(count, static_cast<int>(g.indexed.size()));
  cv::Mat nearest;
  cv::Mat distances;
  g.place_search->knnSearch(v, nearest, distances, k, cv::flann::SearchParams(g.checks));
  for (int i = 0; i < k; ++i) {
    const int row = nearest.at<int>(0, i);
    if (row < 0 || row >= static_cast<int>(g.indexed.size())) continue;
    // FLANN's L2 is squared: for unit vectors |a - b|² = 2 - 2 cos.
    candidates.push_back({static_cast<std::size_t>(g.indexed[static_cast<std::size_t>(row)]),
                          1.0 - static_cast<double>(distances.at<float>(0, i)) / 2.0});
  }
  return candidates;
}

Status PlaceIndex::setLabels(std::vector<std::string> labels) {
  if (!labels.empty() && labels.size() != size()) {
    return invalid("place index: " + std::to_string(labels.size()) + " labels for " + std::to_string(size()) + " keyframes");
  }
  impl_->labels = std::move(labels);
  return Status::ok();
}

const std::vector<std::string>& PlaceIndex::labels() const { return impl_->labels; }

Status PlaceIndex::save(const std::string& path) const {
  const Impl& g = *impl_;
  cv::FileStorage out(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  out << "format_version" << 1 << "binary" << static_cast<int>(g.binary) << "descriptor_cols" << g.descriptor_cols
      << "vocabulary" << g.vocabulary << "idf" << g.idf << "pca_mean" << g.pca_mean << "pca_basis" << g.pca_basis
      << "places" << g.places << "labels" << g.labels;
  return writeFileAtomically(path, out.releaseAndGetString());
}

Expected<PlaceIndex> PlaceIndex::load(const std::string& path, const PlaceIndexOptions& options) {
  PlaceIndex index;
  Impl& g = *index.impl_;
  g.checks = options.search_checks;
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) return invalid(path + ": no place index there (no such file)");
  try {
    cv::FileStorage in(path, cv::FileStorage::READ);
    if (!in.isOpened()) return invalid(path + ": cannot be read as a place index");
    if (static_cast<int>(in["format_version"]) != 1) return invalid(path + ": unknown place index format_version");
    g.binary = static_cast<int>(in["binary"]) != 0;
    g.descriptor_cols = static_cast<int>(in["descriptor_cols"]);
    in["vocabulary"] >> g.vocabulary;
    in["idf"] >> g.idf;
    in["pca_mean"] >> g.pca_mean;
    in["pca_basis"] >> g.pca_basis;
    in["places"] >> g.places;
    const cv::FileNode labels = in["labels"];
    if (!labels.empty()) labels >> g.labels;
  } catch (const cv::Exception& e) {
    return invalid(path + ": corrupt place index (" + e.msg + ")");
  }
  const int words = g.vocabulary.rows;
  const int expected_cols = g.binary ? g.descriptor_cols * 8 : g.descriptor_cols;
  const bool shapes = words >= 2 && g.vocabulary.type() == CV_32F && g.vocabulary.cols == expected_cols &&
                      g.idf.type() == CV_32F && g.idf.rows == 1 && g.idf.cols == words && g.places.type() == CV_32F &&
                      (g.pca_basis.empty() ? g.places.cols == words
                                           : (g.pca_basis.cols == words && g.pca_mean.cols == words &&
                                              g.places.cols == g.pca_basis.rows));
  if (!shapes) return invalid(path + ": the place index's matrices do not fit together (corrupt file?)");
  if (!g.labels.empty() && static_cast<int>(g.labels.size()) != g.places.rows) {
    return invalid(path + ": " + std::to_string(g.labels.size()) + " labels for " + std::to_string(g.places.rows) + " keyframes");
  }
  if (!cv::checkRange(g.vocabulary) || !cv::checkRange(g.idf) || !cv::checkRange(g.places) ||
      (!g.pca_basis.empty() && (!cv::checkRange(g.pca_basis) || !cv::checkRange(g.pca_mean)))) {
    return invalid(path + ": the place index holds non-finite numbers");
  }
  g.indexPlaces();
  return index;
}

}  // namespace homography_teach_repeat
