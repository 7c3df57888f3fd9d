#include "homography_teach_repeat/network/map_keyframe_cache.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <utility>

namespace homography_teach_repeat {

MapKeyframeCache::MapKeyframeCache(std::shared_ptr<const RouteMap> map, const RepeatOptions& options,
                                   std::size_t capacity)
    : map_(std::move(map)), options_(options), capacity_(std::max<std::size_t>(capacity, 1)) {
  options_.mode = RepeatMode::kFastHd;
  options_.require_planes = true;
  options_.plane_feature_tolerance_px = 0.0;      // a keyframe alone has no neighbour to test against
  options_.plane_sigma_from_neighbours = false;   // nor one to compare its plane with
}

Expected<std::shared_ptr<const MapKeyframe>> MapKeyframeCache::get(const KeyframeRef& ref) {
  const std::string key = toString(ref);
  const auto found = entries_.find(key);
  if (found != entries_.end()) {
    recency_.splice(recency_.begin(), recency_, found->second.position);
    return found->second.keyframe;
  }
  auto loaded = load(ref);
  if (!loaded) return loaded.status();
  insert(key, *loaded);
  return *loaded;
}

void MapKeyframeCache::insert(const std::string& key, std::shared_ptr<const MapKeyframe> keyframe) {
  ++loads_;
  if (entries_.size() >= capacity_) {
    entries_.erase(recency_.back());
    recency_.pop_back();
  }
  recency_.push_front(key);
  entries_.emplace(key, Entry{std::move(keyframe), recency_.begin()});
}

void MapKeyframeCache::prefetch(const std::vector<KeyframeRef>& refs, unsigned threads) {
  std::vector<KeyframeRef> missing;
  for (const KeyframeRef& ref : refs) {
    const bool listed = std::any_of(missing.begin(), missing.end(), [&](const KeyframeRef& m) { return m == ref; });
    if (!contains(ref) && !listed) missing.push_back(ref);
  }
  if (missing.size() < 2 || threads < 2) return;  // get() reads it as fast
  std::vector<Expected<std::shared_ptr<const MapKeyframe>>> loaded(missing.size(), Status(StatusCode::kInvalidInput, ""));
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    for (std::size_t i = next++; i < missing.size(); i = next++) loaded[i] = load(missing[i]);
  };
  std::vector<std::thread> workers;
  const std::size_t count = std::min<std::size_t>(threads, missing.size()) - 1;  // this thread works too
  for (std::size_t t = 0; t < count; ++t) workers.emplace_back(work);
  work();
  for (std::thread& w : workers) w.join();
  for (std::size_t i = 0; i < missing.size(); ++i) {
    if (loaded[i]) insert(toString(missing[i]), *loaded[i]);
  }
}

Expected<std::shared_ptr<const MapKeyframe>> MapKeyframeCache::load(const KeyframeRef& ref) const {
  const int position = map_->keyframePosition(ref);
  if (position < 0) return Status(StatusCode::kInvalidInput, toString(ref) + " is not in the map");
  const Route& route = map_->find(ref.route)->route;
  const auto p = static_cast<std::size_t>(position);
  if (!route.keyframes[p].plane) {
    return Status(StatusCode::kInvalidInput, toString(ref) + " has no plane: relocalization needs the teach phase's planes");
  }
  // The keyframe alone as a route, prepared as the repeat prepares its keyframes.
  Route single;
  single.directory = route.directory;
  single.info = route.info;
  single.keyframes.push_back(route.keyframes[p]);
  auto store = KeyframeStore::load(single, options_);
  if (!store) return Status(StatusCode::kInvalidInput, toString(ref) + ": " + store.status().message());
  auto keyframe = std::make_shared<MapKeyframe>();
  keyframe->ref = ref;
  keyframe->position = position;
  keyframe->taught = store->at(0);
  // Whether the teach run turned here needs the neighbours' poses (keyframe_store.h).
  keyframe->taught.turn = (p > 0 && turnedBetween(route.keyframes[p - 1].pose, route.keyframes[p].pose)) ||
                          (p + 1 < route.keyframes.size() && turnedBetween(route.keyframes[p].pose, route.keyframes[p + 1].pose));
  keyframe->experiences = store->experiences(0);
  for (KeyframeReference& e : keyframe->experiences) e.turn = keyframe->taught.turn;
  return std::shared_ptr<const MapKeyframe>(std::move(keyframe));
}

}  // namespace homography_teach_repeat
