// evaluate_place_index: how the place index of a map of routes (docs/map_format.md) scales: for
// synthetic maps of growing size, the time to build and save it, the time and resident memory to
// load the map (every route's index and the place index) in a fresh process, the time per query and
// how often the revisited place is among the candidates.
//
//   rosrun homography_teach_repeat evaluate_place_index --out DIR [--sizes 500,1000,2000,5000]
//       [--descriptors 500] [--binary 1] [--queries 200] [--seen 0.5] [--candidates 10] [--plots 0|1]
//       [--words W] [--dimensions D] [--checks C]   (the index's options; default: PlaceIndexOptions)
//
// Keyframes 0.5 m apart on routes of at most 500 keyframes; keyframe p sees the landmarks of a window
// of --descriptors landmarks starting at p * descriptors / 10 (neighbours share 90 %). A query
// revisits a random keyframe seeing --seen of its landmarks, each descriptor with noise (8 flipped
// bits of 256 for binary descriptors, sigma 0.05 of [0, 1) for float ones). A query counts as found
// when the keyframe or a neighbour is among the first 1 (recall_at_1) or --candidates. The routes'
// keyframe files are tiny (a 64x48 image, one feature): the map's load reads the indices, not them.
// Writes DIR/place_index.json (and DIR/place_index.png with --plots 1); the maps stay in DIR/map_N.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/common/process_memory.h"
#include "homography_teach_repeat/eval/measurement.h"
#include "homography_teach_repeat/eval/plots.h"
#include "homography_teach_repeat/eval/synthetic_places.h"
#include "homography_teach_repeat/network/place_index.h"
#include "homography_teach_repeat/network/route_map.h"

using namespace homography_teach_repeat;
using eval::percentile;
using eval::secondsSince;
namespace fs = std::filesystem;

namespace {

constexpr int kKeyframesPerRoute = 500;
constexpr double kSpacing = 0.5;

// --measure-load DIR: load the map and its place index, print {"load_s", "peak_rss_mib"}.
int measureLoad(const std::string& directory) {
  const auto start = std::chrono::steady_clock::now();
  const auto map = loadRouteMap(directory);
  if (!map) {
    std::cerr << "evaluate_place_index: " << map.status().message() << "\n";
    return 2;
  }
  const auto index = PlaceIndex::load(directory + "/place_index.yml");
  if (!index) {
    std::cerr << "evaluate_place_index: " << index.status().message() << "\n";
    return 2;
  }
  std::size_t keyframes = 0;
  for (const MapRoute& r : map->routes) keyframes += r.route.keyframes.size();
  const nlohmann::json doc = {{"load_s", secondsSince(start)},
                              {"peak_rss_mib", peakResidentMiB()},
                              {"keyframes", keyframes},
                              {"indexed", index->size()}};
  std::cout << doc.dump() << "\n";
  return 0;
}

void writeMap(const std::string& directory, int keyframes, cv::RNG& rng) {
  fs::remove_all(directory);
  fs::create_directories(directory + "/routes");
  RouteMap map;
  map.directory = directory;
  const RouteInfo info = synthetic_places::tinyRouteInfo(FeatureType::kOrb);
  const cv::Mat image(48, 64, CV_8UC1, cv::Scalar(90));
  for (int first = 0, route = 0; first < keyframes; first += kKeyframesPerRoute, ++route) {
    const std::string name = "route" + std::to_string(route);
    auto writer = RouteWriter::create(directory + "/routes/" + name, info);
    if (!writer) throw std::runtime_error(writer.status().message());
    for (int k = first; k < std::min(keyframes, first + kKeyframesPerRoute); ++k) {
      ImageFeatures features;
      features.type = FeatureType::kOrb;
      features.keypoints.emplace_back(cv::Point2f(10.0f, 10.0f), 7.0f);
      features.descriptors = cv::Mat(1, 32, CV_8U);
      rng.fill(features.descriptors, cv::RNG::UNIFORM, 0, 256);
      const Status added = writer->addKeyframe(image, features, {}, Pose2D(kSpacing * (k - first), 2.0 * route, 0.0), k);
      if (!added.isOk()) throw std::runtime_error(added.message());
    }
    const Status committed = commitMapRoute(map, name, "routes/" + name);
    if (!committed.isOk()) throw std::runtime_error(committed.message());
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--measure-load") return measureLoad(argv[2]);
  cli::Arguments args("evaluate_place_index",
                      {{"out", ""}, {"sizes", "500,1000,2000,5000"}, {"descriptors", "500"}, {"binary", "1"},
                       {"queries", "200"}, {"seen", "0.5"}, {"candidates", "10"}, {"plots", "1"},
                       {"words", std::to_string(PlaceIndexOptions().vocabulary_words)},
                       {"dimensions", std::to_string(PlaceIndexOptions().dimensions)},
                       {"checks", std::to_string(PlaceIndexOptions().search_checks)}},
                      "--out DIR [--sizes 500,1000,2000,5000] [--descriptors N] [--binary 0|1] [--queries N]\n"
                      "  [--seen FRACTION] [--candidates K] [--plots 0|1] [--words W] [--dimensions D] [--checks C]");
  args.parse(argc, argv);
  if (args.text("out").empty()) args.fail("--out is required");
  const std::vector<int> sizes = eval::scaleSizes(args, 2);
  const int descriptors = args.integer("descriptors");
  const int queries = args.integer("queries");
  const int candidates = args.integer("candidates");
  const double seen = args.number("seen");
  if (descriptors < 10 || queries < 1 || candidates < 1 || !(seen > 0.0 && seen <= 1.0)) {
    args.fail("--descriptors >= 10, --queries >= 1, --candidates >= 1, 0 < --seen <= 1");
  }
  const bool binary = args.integer("binary") != 0;
  PlaceIndexOptions options;  // the defaults, unless the index itself is being studied
  options.vocabulary_words = args.integer("words");
  options.dimensions = args.integer("dimensions");
  options.search_checks = args.integer("checks");
  const double noise = binary ? 8.0 : 0.05;
  try {
    const fs::path out(args.text("out"));
    fs::create_directories(out);
    nlohmann::json doc;
    doc["kind"] = "place_index";
    doc["descriptors_per_keyframe"] = descriptors;
    doc["binary"] = binary;
    doc["seen"] = seen;
    doc["candidates"] = candidates;
    doc["words"] = options.vocabulary_words;
    doc["dimensions"] = options.dimensions;
    doc["checks"] = options.search_checks;
    doc["sizes"] = nlohmann::json::array();
    for (const int size : sizes) {
      cv::RNG rng(static_cast<std::uint64_t>(size));
      const auto world = synthetic_places::makeWorld(size, descriptors, std::max(1, descriptors / 10), binary);
      std::vector<cv::Mat> taught;
      for (int p = 0; p < size; ++p) taught.push_back(synthetic_places::visit(world, p, 0.9, noise, rng));
      const std::string map_dir = (out / ("map_" + std::to_string(size))).string();
      writeMap(map_dir, size, rng);
      auto start = std::chrono::steady_clock::now();
      const auto index = PlaceIndex::build(taught, options);
      if (!index) throw std::runtime_error(index.status().message());
      const double build_s = secondsSince(start);
      const Status saved = index->save(map_dir + "/place_index.yml");
      if (!saved.isOk()) throw std::runtime_error(saved.message());

      // The load in a fresh process, so that its peak resident memory is the map's alone.
      const std::string command = "'" + std::string(argv[0]) + "' --measure-load '" + map_dir + "'";
      const auto load = eval::runForJson(command);

      std::vector<double> query_ms;
      int at_1 = 0;
      int at_k = 0;
      for (int q = 0; q < queries; ++q) {
        const int place = rng.uniform(0, size);
        const cv::Mat visit = synthetic_places::visit(world, place, seen, noise, rng);
        start = std::chrono::steady_clock::now();
        const auto found = index->query(visit, candidates);
        query_ms.push_back(1000.0 * secondsSince(start));
        if (!found) throw std::runtime_error(found.status().message());
        for (std::size_t i = 0; i < found->size(); ++i) {
          if (std::abs(static_cast<int>((*found)[i].place) - place) > 1) continue;
          at_1 += i == 0 ? 1 : 0;
          ++at_k;
          break;
        }
      }
      nlohmann::json row = {{"keyframes", size},
                            {"route_length_m", kSpacing * size},
                            {"build_s", build_s},
                            {"index_file_mib", static_cast<double>(fs::file_size(map_dir + "/place_index.yml")) / (1024.0 * 1024.0)},
                            {"load_s", load["load_s"]},
                            {"load_peak_rss_mib", load["peak_rss_mib"]},
                            {"query_ms_median", percentile(query_ms, 0.5)},
                            {"query_ms_p95", percentile(query_ms, 0.95)},
                            {"recall_at_1", static_cast<double>(at_1) / queries},
                            {"recall_at_k", static_cast<double>(at_k) / queries}};
      std::printf("%5d keyframes: build %.1f s, load %.2f s and %.0f MiB, query median %.2f ms (p95 %.2f), "
                  "found first %.0f %%, among %d %.0f %%\n",
                  size, build_s, row["load_s"].get<double>(), row["load_peak_rss_mib"].get<double>(),
                  row["query_ms_median"].get<double>(), row["query_ms_p95"].get<double>(), 100.0 * at_1 / queries,
                  candidates, 100.0 * at_k / queries);
      std::fflush(stdout);
      doc["sizes"].push_back(row);
    }
    const auto& rows = doc["sizes"];
    if (rows.size() >= 2) {
      const double size_ratio = rows.back()["keyframes"].get<double>() / rows.front()["keyframes"].get<double>();
      doc["query_growth"] = {{"size_ratio", size_ratio},
                             {"median_ratio", rows.back()["query_ms_median"].get<double>() /
                                                  rows.front()["query_ms_median"].get<double>()}};
    }
    const std::string json_path = (out / "place_index.json").string();
    std::ofstream(json_path) << doc.dump(2) << "\n";
    if (args.integer("plots") != 0 && eval::drawPlots(json_path, "evaluate_place_index") != 0) return 1;
  } catch (const std::exception& e) {
    std::cerr << "evaluate_place_index: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
