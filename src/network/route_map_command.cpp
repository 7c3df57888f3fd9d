#include "homography_teach_repeat/network/route_map_command.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>

#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/network/junction_measurement.h"
#include "homography_teach_repeat/network/map_place_index.h"
#include "homography_teach_repeat/network/map_relocalizer.h"
#include "homography_teach_repeat/network/route_graph.h"
#include "homography_teach_repeat/network/route_map.h"

namespace homography_teach_repeat {
namespace {

const char* const kUsage =
    "usage: route_map list MAP [--json]\n"
    "       route_map migrate MAP [NAME]\n"
    "       route_map add MAP NAME ROUTE_DIR\n"
    "       route_map rename MAP OLD NEW\n"
    "       route_map remove MAP NAME\n"
    "       route_map remove-junctions MAP ROUTE[:KEYFRAME]\n"
    "       route_map plan MAP FROM_ROUTE:KEYFRAME TO_ROUTE:KEYFRAME [--json]\n"
    "       route_map junction MAP FROM_ROUTE:KEYFRAME TO_ROUTE:KEYFRAME\n"
    "       route_map index MAP\n"
    "       route_map locate MAP IMAGE [--json]\n";

struct UsageError {
  std::string message;
};

// "route:12" (or "route" alone when `keyframe_optional`, keyframe -1).
KeyframeRef parseRef(const std::string& text, bool keyframe_optional) {
  if (keyframe_optional && text.find(':') == std::string::npos) return KeyframeRef{text, -1};
  auto ref = parseKeyframeRef(text);
  if (!ref) throw UsageError{ref.status().message()};
  return *ref;
}

double routeLength(const Route& route) {
  double length = 0.0;
  for (std::size_t k = 1; k < route.keyframes.size(); ++k) {
    const Pose2D& a = route.keyframes[k - 1].pose;
    const Pose2D& b = route.keyframes[k].pose;
    length += std::hypot(b.x - a.x, b.y - a.y);
  }
  return length;
}

nlohmann::json describe(const RouteMap& map) {
  nlohmann::json doc;
  doc["directory"] = map.directory;
  doc["format_version"] = map.loaded_format_version;
  doc["routes"] = nlohmann::json::array();
  for (const MapRoute& r : map.routes) {
    doc["routes"].push_back({{"name", r.name},
                             {"directory", r.directory},
                             {"keyframes", r.route.keyframes.size()},
                             {"length_m", routeLength(r.route)},
                             {"closed", isClosedRoute(r.route, RouteGraphOptions().closed_route_gap)}});
  }
  doc["junctions"] = nlohmann::json::array();
  for (const Junction& j : map.junctions) {
    doc["junctions"].push_back({{"from", toString(j.from)},
                                {"to", toString(j.to)},
                                {"distance_m", std::hypot(j.to_in_from.x, j.to_in_from.y)},
                                {"yaw_deg", j.to_in_from.yaw * 180.0 / M_PI},
                                {"inliers", j.inliers}});
  }
  doc["orphan_folders"] = listRouteMapOrphans(map);
  return doc;
}

void printList(const nlohmann::json& doc, std::ostream& out) {
  out << "map " << doc["directory"].get<std::string>() << " (format " << doc["format_version"].get<int>() << ")\n";
  out << std::fixed << std::setprecision(2);
  for (const auto& r : doc["routes"]) {
    out << "  route " << r["name"].get<std::string>() << ": " << r["keyframes"].get<int>() << " keyframes, "
        << r["length_m"].get<double>() << " m" << (r["closed"].get<bool>() ? ", closed" : "") << " ("
        << r["directory"].get<std::string>() << ")\n";
  }
  for (const auto& j : doc["junctions"]) {
    out << "  junction " << j["from"].get<std::string>() << " -> " << j["to"].get<std::string>() << ": "
        << j["distance_m"].get<double>() << " m, " << j["yaw_deg"].get<double>() << " deg, "
        << j["inliers"].get<int>() << " inliers\n";
  }
  for (const auto& folder : doc["orphan_folders"]) {
    out << "  not in the index (left by an interrupted teach or removal): " << folder.get<std::string>() << "\n";
  }
}

RouteMap load(const std::string& directory) {
  auto map = loadRouteMap(directory);
  if (!map) throw UsageError{map.status().message()};
  return std::move(*map);
}

void check(const Status& status) {
  if (!status.isOk()) throw UsageError{status.message()};
}

}  // namespace

int runRouteMapCommand(const std::vector<std::string>& raw_args, std::ostream& out, std::ostream& err) {
  std::vector<std::string> args;
  bool json = false;
  for (const std::string& a : raw_args) {
    if (a == "--help" || a == "-h") {
      out << kUsage;
      return 0;
    }
    if (a == "--json") {
      json = true;
    } else {
      args.push_back(a);
    }
  }
  try {
    if (args.size() < 2) throw UsageError{"a command and a map folder are needed"};
    const std::string& command = args[0];
    const std::string& directory = args[1];
    auto expectArgs = [&](std::size_t low, std::size_t high) {
      if (args.size() < low || args.size() > high) throw UsageError{"wrong number of arguments for '" + command + "'"};
    };
    if (command == "list") {
      expectArgs(2, 2);
      const nlohmann::json doc = describe(load(directory));
      if (json) {
        out << doc.dump(2) << "\n";
      } else {
        printList(doc, out);
      }
    } else if (command == "migrate") {
      expectArgs(2, 3);
      check(migrateToRouteMap(directory, args.size() == 3 ? args[2] : "route"));
      out << "map.yaml written in " << directory << "\n";
    } else if (command == "add") {
      expectArgs(4, 4);
      namespace fs = std::filesystem;
      const std::string& name = args[2];
      const auto source = loadRoute(args[3]);
      if (!source) throw UsageError{source.status().message()};
      RouteMap map;
      map.directory = directory;
      std::error_code error;
      if (fs::exists(fs::path(directory) / "map.yaml", error) || fs::exists(fs::path(directory) / "route.yaml", error)) {
        map = load(directory);
      } else {
        fs::create_directories(directory, error);
        if (error) throw UsageError{"cannot create the map folder '" + directory + "': " + error.message()};
      }
      if (!isValidRouteName(name)) throw UsageError{"'" + name + "' is not a route name ([A-Za-z0-9_-]+)"};
      const bool replacing = map.find(name) != nullptr;
      // Copied into a folder the index does not name yet, then committed (a crash leaves an orphan).
      const std::string relative = newRouteDirectory(map, name);
      fs::create_directories((fs::path(directory) / relative).parent_path(), error);
      fs::copy(args[3], fs::path(directory) / relative, fs::copy_options::recursive, error);
      if (error) throw UsageError{"cannot copy '" + args[3] + "' into the map: " + error.message()};
      std::vector<Junction> dropped;
      const Status committed = commitMapRoute(map, name, relative, &dropped);
      if (!committed.isOk()) {
        fs::remove_all(fs::path(directory) / relative, error);
        throw UsageError{committed.message()};
      }
      out << (replacing ? "replaced " : "added ") << name << " (" << source->keyframes.size() << " keyframes) as "
          << relative << "\n";
      for (const Junction& j : dropped) {
        out << "  junction " << toString(j.from) << " -> " << toString(j.to) << " dropped (its keyframe is gone)\n";
      }
    } else if (command == "rename") {
      expectArgs(4, 4);
      RouteMap map = load(directory);
      check(renameMapRoute(map, args[2], args[3]));
      out << "renamed " << args[2] << " to " << args[3] << "\n";
    } else if (command == "remove") {
      expectArgs(3, 3);
      RouteMap map = load(directory);
      check(removeMapRoute(map, args[2]));
      out << "removed " << args[2] << "\n";
    } else if (command == "remove-junctions") {
      expectArgs(3, 3);
      RouteMap map = load(directory);
      const auto removed = removeJunctions(map, parseRef(args[2], /*keyframe_optional=*/true));
      if (!removed) throw UsageError{removed.status().message()};
      out << "removed " << *removed << " junction" << (*removed == 1 ? "" : "s") << "\n";
    } else if (command == "plan") {
      expectArgs(4, 4);
      const RouteMap map = load(directory);
      const KeyframeRef from = parseRef(args[2], false);
      const KeyframeRef to = parseRef(args[3], false);
      const auto path = RouteGraph(map).shortestPath(from, to);
      if (!path) {
        err << "route_map: " << path.status().message() << "\n";
        return path.status().code() == StatusCode::kNoConsensus ? 3 : 2;
      }
      nlohmann::json doc = {{"from", toString(from)},
                            {"to", toString(to)},
                            {"length_m", path->length_m},
                            {"junctions_crossed", path->junctions_crossed},
                            {"keyframes", nlohmann::json::array()}};
      for (const KeyframeRef& k : path->keyframes) doc["keyframes"].push_back(toString(k));
      if (json) {
        out << doc.dump(2) << "\n";
      } else {
        out << std::fixed << std::setprecision(2) << toString(from) << " -> " << toString(to) << ": "
            << path->length_m << " m, " << path->keyframes.size() << " keyframes, " << path->junctions_crossed
            << " junction" << (path->junctions_crossed == 1 ? "" : "s") << "\n";
        for (std::size_t i = 0; i < path->keyframes.size(); ++i) {
          const bool change = i > 0 && path->keyframes[i].route != path->keyframes[i - 1].route;
          if (i == 0 || change || i + 1 == path->keyframes.size()) {
            out << "  " << (change ? "junction to " : "") << toString(path->keyframes[i]) << "\n";
          }
        }
      }
    } else if (command == "junction") {
      expectArgs(4, 4);
      RouteMap map = load(directory);
      const auto junction =
          measureJunction(map, parseRef(args[2], false), parseRef(args[3], false), RepeatOptions());
      if (!junction) throw UsageError{junction.status().message()};
      check(addJunction(map, *junction));
      out << std::fixed << std::setprecision(3) << "junction " << toString(junction->from) << " -> "
          << toString(junction->to) << ": x " << junction->to_in_from.x << " m, y " << junction->to_in_from.y
          << " m, yaw " << junction->to_in_from.yaw * 180.0 / M_PI << " deg (sigma " << std::sqrt(junction->covariance(0, 0))
          << ", " << std::sqrt(junction->covariance(1, 1)) << " m, " << std::sqrt(junction->covariance(2, 2)) * 180.0 / M_PI
          << " deg), " << junction->inliers << " inliers; added\n";
    } else if (command == "index") {
      expectArgs(2, 2);
      const RouteMap map = load(directory);
      const auto start = std::chrono::steady_clock::now();
      const auto index = buildMapPlaceIndex(map);
      if (!index) throw UsageError{index.status().message()};
      check(index->save(mapPlaceIndexPath(map)));
      out << std::fixed << std::setprecision(1) << mapPlaceIndexPath(map) << ": " << index->size() << " keyframes, "
          << index->words() << " words, built in "
          << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() << " s\n";
    } else if (command == "locate") {
      expectArgs(3, 3);
      const RouteMap map = load(directory);
      auto index = loadMapPlaceIndex(map);
      if (!index) throw UsageError{index.status().message()};
      const cv::Mat image = cv::imread(args[2], cv::IMREAD_GRAYSCALE);
      if (image.empty()) throw UsageError{"cannot read the image '" + args[2] + "'"};
      RepeatOptions repeat;  // the defaults, with the map's feature type (the routes' info)
      FeatureOptions feature_options;
      feature_options.type = map.routes.front().route.info.feature_type;
      feature_options.max_features = repeat.max_features;
      const auto features = FeatureExtractor(feature_options).extract(image);
      if (!features) throw UsageError{args[2] + ": " + features.status().message()};
      const auto candidates = index->query(features->descriptors, RelocalizationOptions().candidates);
      if (!candidates) throw UsageError{candidates.status().message()};
      nlohmann::json doc = {{"image", args[2]}, {"features", features->keypoints.size()},
                            {"candidates", nlohmann::json::array()}, {"places", nlohmann::json::array()}};
      for (const PlaceCandidate& c : *candidates) {
        doc["candidates"].push_back({{"keyframe", toString(keyframeOf(*index, c))}, {"similarity", c.similarity}});
      }
      // The candidates' geometry: every one checked in this one frame (relocalization's first frame).
      RelocalizationOptions relocalization;
      relocalization.checks_per_frame = relocalization.candidates;
      auto relocalizer = MapRelocalizer::create(map, std::move(*index), repeat, relocalization);
      if (!relocalizer) throw UsageError{relocalizer.status().message()};
      const auto located = relocalizer->update(image, Pose2D());
      if (!located) throw UsageError{args[2] + ": " + located.status().message()};
      for (const PlaceHypothesis& h : located->hypotheses) {
        doc["places"].push_back({{"keyframe", toString(h.keyframe)},
                                 {"x", h.base_pose.x}, {"y", h.base_pose.y}, {"yaw", h.base_pose.yaw},
                                 {"sigma_xy_m", std::sqrt(std::max(0.0, h.covariance(0, 0) + h.covariance(1, 1)))},
                                 {"inliers", h.inliers}});
      }
      doc["problems"] = located->problems;
      if (json) {
        out << doc.dump(2) << "\n";
      } else {
        out << std::fixed << std::setprecision(3) << "candidates (place index):\n";
        for (const auto& c : doc["candidates"]) {
          out << "  " << c["keyframe"].get<std::string>() << "  similarity " << c["similarity"].get<double>() << "\n";
        }
        out << "places whose geometry fits (base_link in the route's frame):\n";
        if (doc["places"].empty()) out << "  none\n";
        for (const auto& p : doc["places"]) {
          out << "  " << p["keyframe"].get<std::string>() << "  x " << p["x"].get<double>() << " m  y "
              << p["y"].get<double>() << " m  yaw " << p["yaw"].get<double>() << " rad  inliers "
              << p["inliers"].get<int>() << "\n";
        }
        for (const std::string& problem : located->problems) out << "  problem: " << problem << "\n";
      }
    } else {
      throw UsageError{"unknown command '" + command + "'"};
    }
  } catch (const UsageError& e) {
    err << "route_map: " << e.message << "\n" << kUsage;
    return 2;
  }
  return 0;
}

}  // namespace homography_teach_repeat
