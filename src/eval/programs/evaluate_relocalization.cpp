// evaluate_relocalization: finding the place without a hint in maps of growing size
// (docs/map_format.md, "Finding the place without a hint"; docs/evaluation.md, "Relocalization"):
// for each size, a map of corridors is taught from rendered images, its place index built, and in a
// fresh process the map is loaded and the robot set down at random places with no hint, driving on
// until MapRelocalizer confirms a place (or gives up): the load time, the peak resident memory,
// the time of each frame, how many frames and metres it took and whether the place was right.
//
//   rosrun homography_teach_repeat evaluate_relocalization --out DIR [--sizes 500,5000] [--queries 30]
//       [--feature sift] [--max-features 1500] [--max-frames 30] [--plots 0|1]
//
// The world: corridors of 500 keyframes (250 m) each, in a frame of their own; a camera looking
// left (camera_mount yaw +90°) at a wall 3 m away, 640x480, fx 500; the wall's texture is new every
// metre (random shapes), and every corridor's is its own, so no two places look alike. A set-down
// is a random place of a random corridor, off the taught line by up to 0.2 m, turned by up to 6°,
// seen with another gain and pixel noise; the robot then drives 0.1 m per frame along the corridor.
// Writes DIR/relocalization.json (and DIR/relocalization.png with --plots 1); maps stay in DIR/map_N.
#include <nlohmann/json.hpp>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/command_line.h"
#include "homography_teach_repeat/common/process_memory.h"
#include "homography_teach_repeat/eval/measurement.h"
#include "homography_teach_repeat/eval/plots.h"
#include "homography_teach_repeat/network/map_place_index.h"
#include "homography_teach_repeat/network/map_relocalizer.h"
#include "homography_teach_repeat/network/route_map.h"

using namespace homography_teach_repeat;
using eval::percentile;
using eval::secondsSince;
namespace fs = std::filesystem;

namespace {

constexpr int kKeyframesPerRoute = 500;
constexpr double kSpacing = 0.5;        // [m] between keyframes
constexpr double kWallDistance = 3.0;   // [m] from the taught line
constexpr double kWallHeight = 2.5;     // [m]
constexpr double kCameraHeight = 1.2;   // [m]
constexpr double kPixelsPerMetre = 200.0;

CameraCalibration camera() {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 500.0;
  c.cx = 319.5;
  c.cy = 239.5;
  c.distortion_model = "plumb_bob";
  c.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};
  return c;
}

// The corridors' walls: one texture tile per metre, drawn from (corridor, metre) alone.
class Corridors {
 public:
  cv::Mat tile(int corridor, int metre) {
    const long key = static_cast<long>(corridor) * 1000003L + metre;
    const auto found = tiles_.find(key);
    if (found != tiles_.end()) return found->second;
    if (tiles_.size() > 64) tiles_.clear();
    cv::RNG rng(static_cast<std::uint64_t>(key) * 2654435761ULL + 17);
    const int w = static_cast<int>(kPixelsPerMetre);
    const int h = static_cast<int>(kWallHeight * kPixelsPerMetre);
    cv::Mat t(h, w, CV_8UC1, cv::Scalar(rng.uniform(90, 170)));
    for (int i = 0; i < 160; ++i) {
      const cv::Point c(rng.uniform(0, w), rng.uniform(0, h));
      const int size = rng.uniform(4, 30);
      const cv::Scalar grey(rng.uniform(0, 256));
      if (rng.uniform(0, 2) == 0) {
        cv::rectangle(t, cv::Rect(c.x, c.y, size, rng.uniform(4, 30)), grey, cv::FILLED);
      } else {
        cv::circle(t, c, size / 2, grey, cv::FILLED);
      }
    }
    cv::GaussianBlur(t, t, cv::Size(3, 3), 0.8);
    tiles_[key] = t;
    return t;
  }

  // The image of a camera on base_link at `base` (corridor frame: x along it, the wall at
  // y = kWallDistance on the left), looking left.
  cv::Mat imageAt(int corridor, const Pose2D& base) {
    const int first = static_cast<int>(std::floor(base.x - 3.0));
    const int last = static_cast<int>(std::floor(base.x + 3.0));
    std::vector<cv::Mat> tiles;
    for (int m = first; m <= last; ++m) tiles.push_back(tile(corridor, m));
    cv::Mat strip;
    cv::hconcat(tiles, strip);
    // Strip pixel (u, v) is the wall point X = first + u / ppm, Z = height - v / ppm.
    const double a = base.yaw + M_PI / 2.0;
    const Eigen::Vector3d forward(std::cos(a), std::sin(a), 0.0), right(std::cos(base.yaw), std::sin(base.yaw), 0.0),
        down(0.0, 0.0, -1.0), centre(base.x, base.y, kCameraHeight);
    const CameraCalibration c = camera();
    std::vector<cv::Point2f> from, to;
    for (const cv::Point2f corner : {cv::Point2f(0, 0), cv::Point2f(static_cast<float>(strip.cols), 0),
                                     cv::Point2f(0, static_cast<float>(strip.rows)),
                                     cv::Point2f(static_cast<float>(strip.cols), static_cast<float>(strip.rows))}) {
      const Eigen::Vector3d p(first + corner.x / kPixelsPerMetre, kWallDistance, kWallHeight - corner.y / kPixelsPerMetre);
      const Eigen::Vector3d d = p - centre;
      const double z = forward.dot(d);
      from.push_back(corner);
      to.emplace_back(static_cast<float>(c.fx * right.dot(d) / z + c.cx), static_cast<float>(c.fy * down.dot(d) / z + c.cy));
    }
    cv::Mat image;
    cv::warpPerspective(strip, image, cv::getPerspectiveTransform(from, to), cv::Size(c.width, c.height),
                        cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(70));
    return image;
  }

 private:
  std::map<long, cv::Mat> tiles_;
};

// The wall in the camera frame of a keyframe on the taught line (y = 0, yaw 0): straight ahead.
ScenePlane keyframePlane() { return ScenePlane{Eigen::Vector3d::UnitZ(), kWallDistance}; }

void writeMap(const std::string& directory, int keyframes, const FeatureOptions& features) {
  fs::remove_all(directory);
  fs::create_directories(directory + "/routes");
  RouteMap map;
  map.directory = directory;
  RouteInfo info;
  info.feature_type = features.type;
  info.camera = camera();
  info.camera_mount = Pose2D(0.0, 0.0, M_PI / 2.0);
  info.first_plane_distance = kWallDistance;
  FeatureExtractor extractor(features);
  Corridors corridors;
  for (int first = 0, corridor = 0; first < keyframes; first += kKeyframesPerRoute, ++corridor) {
    const std::string name = "corridor" + std::to_string(corridor);
    auto writer = RouteWriter::create(directory + "/routes/" + name, info);
    if (!writer) throw std::runtime_error(writer.status().message());
    std::vector<std::optional<ScenePlane>> planes;
    for (int k = first; k < std::min(keyframes, first + kKeyframesPerRoute); ++k) {
      const Pose2D pose(kSpacing * (k - first), 0.0, 0.0);
      const cv::Mat image = corridors.imageAt(corridor, pose);
      const auto extracted = extractor.extract(image);
      if (!extracted) throw std::runtime_error(extracted.status().message());
      const Status added = writer->addKeyframe(image, *extracted, {}, pose, k);
      if (!added.isOk()) throw std::runtime_error(added.message());
      planes.emplace_back(keyframePlane());
    }
    const Status planned = writer->setPlanes(planes, kWallDistance);
    if (!planned.isOk()) throw std::runtime_error(planned.message());
    const Status committed = commitMapRoute(map, name, "routes/" + name);
    if (!committed.isOk()) throw std::runtime_error(committed.message());
  }
}

// --measure DIR QUERIES MAX_FRAMES MAX_FEATURES: in a fresh process, load the map and relocalize at QUERIES
// set-down places; prints one JSON object.
int measure(const std::string& directory, int queries, int max_frames, int max_features) {
  keepFreedMemoryForReuse();  // as repeat_node does
  auto start = std::chrono::steady_clock::now();
  const auto map = loadRouteMap(directory);
  if (!map) throw std::runtime_error(map.status().message());
  auto index = loadMapPlaceIndex(*map);
  if (!index) throw std::runtime_error(index.status().message());
  RepeatOptions repeat;
  repeat.max_features = max_features;
  auto relocalizer = MapRelocalizer::create(*map, std::move(*index), repeat);
  if (!relocalizer) throw std::runtime_error(relocalizer.status().message());
  const double load_s = secondsSince(start);
  const double load_rss = peakResidentMiB();
  relocalizer->warmUp();  // as a node does at start-up

  Corridors corridors;
  cv::RNG rng(4242);
  std::vector<double> frame_ms, first_frame_ms, frames_to_confirm, metres_to_confirm;
  int right = 0, wrong = 0, unconfirmed = 0;
  double worst_error_m = 0.0;
  nlohmann::json slowest = {{"ms", 0.0}};
  for (int q = 0; q < queries; ++q) {
    relocalizer->reset();
    const int corridor = rng.uniform(0, static_cast<int>(map->routes.size()));
    const MapRoute& route = map->routes[static_cast<std::size_t>(corridor)];
    const double length = kSpacing * static_cast<double>(route.route.keyframes.size() - 1);
    const double along = rng.uniform(0.5, std::max(0.6, length - 0.1 * max_frames - 0.5));
    const Pose2D set_down(along, rng.uniform(-0.2, 0.2), rng.uniform(-0.1, 0.1));
    const Pose2D odometry_origin(rng.uniform(-50.0, 50.0), rng.uniform(-50.0, 50.0), rng.uniform(-M_PI, M_PI));
    const double gain = rng.uniform(0.8, 1.2);
    bool done = false;
    for (int f = 0; f < max_frames && !done; ++f) {
      const Pose2D truth = set_down.compose(Pose2D(0.1 * f, 0.0, 0.0));
      cv::Mat image = corridors.imageAt(corridor, truth);
      cv::Mat noise(image.size(), CV_16S);
      rng.fill(noise, cv::RNG::NORMAL, 0, 3);
      cv::Mat brighter;
      image.convertTo(brighter, CV_16S, gain);
      cv::Mat(brighter + noise).convertTo(image, CV_8U);
      const auto frame_start = std::chrono::steady_clock::now();
      const auto result = relocalizer->update(image, odometry_origin.compose(truth));
      const double ms = 1000.0 * secondsSince(frame_start);
      if (!result) throw std::runtime_error(result.status().message());
      frame_ms.push_back(ms);
      if (ms > slowest["ms"].get<double>()) {
        const RelocalizationTiming& t = result->timing;
        slowest = {{"ms", ms}, {"frame", f}, {"extraction_ms", t.extraction_ms}, {"query_ms", t.query_ms},
                   {"checks_ms", t.checks_ms}, {"checks", t.checks}, {"loads", t.loads},
                   {"state", toString(result->state)}};
      }
      if (f == 0) first_frame_ms.push_back(ms);
      if (result->state != RelocalizationState::kConfirmed) continue;
      done = true;
      const PlaceHypothesis& place = *result->place;
      const double error = std::hypot(place.base_pose.x - truth.x, place.base_pose.y - truth.y);
      if (place.keyframe.route == route.name && error < 0.3) {
        ++right;
        worst_error_m = std::max(worst_error_m, error);
        frames_to_confirm.push_back(f + 1);
        metres_to_confirm.push_back(0.1 * f);
      } else {
        ++wrong;
        std::cerr << "wrong place: " << toString(place.keyframe) << " for " << route.name << " at " << truth.x
                  << " m (error " << error << " m)\n";
      }
    }
    if (!done) ++unconfirmed;
  }
  const nlohmann::json doc = {{"load_s", load_s},
                              {"load_peak_rss_mib", load_rss},
                              {"peak_rss_mib", peakResidentMiB()},
                              {"keyframes_loaded", relocalizer->keyframes().loads()},
                              {"frame_ms_median", percentile(frame_ms, 0.5)},
                              {"frame_ms_p95", percentile(frame_ms, 0.95)},
                              {"frame_ms_max", percentile(frame_ms, 1.0)},
                              {"first_frame_ms_median", percentile(first_frame_ms, 0.5)},
                              {"slowest_frame", slowest},
                              {"frames_to_confirm_median", percentile(frames_to_confirm, 0.5)},
                              {"frames_to_confirm_max", percentile(frames_to_confirm, 1.0)},
                              {"metres_to_confirm_median", percentile(metres_to_confirm, 0.5)},
                              {"right", right},
                              {"wrong", wrong},
                              {"unconfirmed", unconfirmed},
                              {"worst_position_error_m", worst_error_m}};
  std::cout << doc.dump() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 6 && std::string(argv[1]) == "--measure") {
      return measure(argv[2], std::stoi(argv[3]), std::stoi(argv[4]), std::stoi(argv[5]));
    }
  } catch (const std::exception& e) {
    std::cerr << "evaluate_relocalization: " << e.what() << "\n";
    return 1;
  }
  cli::Arguments args("evaluate_relocalization",
                      {{"out", ""}, {"sizes", "500,5000"}, {"queries", "30"}, {"feature", "sift"},
                       {"max-features", std::to_string(RepeatOptions().max_features)}, {"max-frames", "30"},
                       {"plots", "1"}},
                      "--out DIR [--sizes 500,5000] [--queries N] [--feature sift|orb|akaze] [--max-features N]\n"
                      "  [--max-frames N] [--plots 0|1]");
  args.parse(argc, argv);
  if (args.text("out").empty()) args.fail("--out is required");
  const std::vector<int> sizes = eval::scaleSizes(args, 10);
  const int queries = args.integer("queries");
  const int max_frames = args.integer("max-frames");
  if (queries < 1 || max_frames < 1) args.fail("--queries >= 1, --max-frames >= 1");
  FeatureOptions features;
  try {
    features.type = featureTypeFromString(args.text("feature"));
    features.max_features = args.integer("max-features");
    features.validate();
  } catch (const std::invalid_argument& e) {
    args.fail(e.what());
  }
  try {
    const fs::path out(args.text("out"));
    fs::create_directories(out);
    nlohmann::json doc;
    doc["kind"] = "relocalization";
    doc["feature"] = toString(features.type);
    doc["max_features"] = features.max_features;
    doc["queries"] = queries;
    doc["max_frames"] = max_frames;
    doc["sizes"] = nlohmann::json::array();
    for (const int size : sizes) {
      const std::string map_dir = (out / ("map_" + std::to_string(size))).string();
      auto start = std::chrono::steady_clock::now();
      writeMap(map_dir, size, features);
      const double teach_s = secondsSince(start);
      start = std::chrono::steady_clock::now();
      auto map = loadRouteMap(map_dir);
      if (!map) throw std::runtime_error(map.status().message());
      const auto index = buildMapPlaceIndex(*map);
      if (!index) throw std::runtime_error(index.status().message());
      const Status saved = index->save(mapPlaceIndexPath(*map));
      if (!saved.isOk()) throw std::runtime_error(saved.message());
      const double index_s = secondsSince(start);

      // The relocalization in a fresh process, so that its resident memory is the map's alone.
      const std::string command = "'" + std::string(argv[0]) + "' --measure '" + map_dir + "' " +
                                  std::to_string(queries) + " " + std::to_string(max_frames) + " " +
                                  std::to_string(features.max_features);
      nlohmann::json row = eval::runForJson(command);
      row["keyframes"] = size;
      row["length_m"] = kSpacing * size;
      row["teach_s"] = teach_s;
      row["index_build_s"] = index_s;
      std::printf("%5d keyframes: load %.2f s, peak %.0f MiB, frame median %.0f ms (p95 %.0f, max %.0f), "
                  "confirmed right %d, wrong %d, not %d of %d, after %.0f frames (median)\n",
                  size, row["load_s"].get<double>(), row["peak_rss_mib"].get<double>(),
                  row["frame_ms_median"].get<double>(), row["frame_ms_p95"].get<double>(),
                  row["frame_ms_max"].get<double>(), row["right"].get<int>(), row["wrong"].get<int>(),
                  row["unconfirmed"].get<int>(), queries,
                  row["frames_to_confirm_median"].is_number() ? row["frames_to_confirm_median"].get<double>() : NAN);
      std::fflush(stdout);
      doc["sizes"].push_back(row);
    }
    const auto& rows = doc["sizes"];
    if (rows.size() >= 2) {
      doc["growth"] = {{"size_ratio", rows.back()["keyframes"].get<double>() / rows.front()["keyframes"].get<double>()},
                       {"frame_median_ratio",
                        rows.back()["frame_ms_median"].get<double>() / rows.front()["frame_ms_median"].get<double>()},
                       {"load_ratio", rows.back()["load_s"].get<double>() / rows.front()["load_s"].get<double>()}};
    }
    const std::string json_path = (out / "relocalization.json").string();
    std::ofstream(json_path) << doc.dump(2) << "\n";
    if (args.integer("plots") != 0 && eval::drawPlots(json_path, "evaluate_relocalization") != 0) return 1;
  } catch (const std::exception& e) {
    std::cerr << "evaluate_relocalization: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
