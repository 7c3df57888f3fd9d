// The keyframes of a map of routes as relocalization localizes against them
// (docs/map_format.md, "Finding the place without a hint"): each keyframe's stored features, pose,
// plane and learned views (experiences), read from its files when first asked for and kept up to a
// capacity (the least recently used is dropped), so that a map of thousands of keyframes is never
// held in memory at once. A keyframe is prepared alone (no neighbour restricts its features to its
// plane or measures its plane's agreement, keyframe_store.h): the fast_hd checks of the plane
// (residual, normal) and the confirmation over several frames (map_relocalizer.h) guard instead.
#pragma once

#include <cstddef>
#include <list>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/teach_repeat/keyframe_store.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

namespace homography_teach_repeat {

struct MapKeyframe {
  KeyframeRef ref;
  int position = 0;                              // in its route's keyframes
  KeyframeReference taught;                      // route frame of its route
  std::vector<KeyframeReference> experiences;    // newest first (RepeatOptions::use_experiences)
};

class MapKeyframeCache {
 public:
  // `map` must outlive the cache. `options`: the repeat's; the keyframes are prepared for fast_hd.
  MapKeyframeCache(std::shared_ptr<const RouteMap> map, const RepeatOptions& options, std::size_t capacity);

  // The keyframe, read from its files on first use. kInvalidInput naming the keyframe when it is
  // not in the map, has no plane (a pose needs it), or its files are missing or corrupt.
  Expected<std::shared_ptr<const MapKeyframe>> get(const KeyframeRef& ref);

  // Reads those of `refs` not yet in memory side by side on up to `threads` threads (reading a
  // keyframe is mostly parsing its features file: ~25 ms for 1,500 SIFT features), so that the
  // get() calls that follow find them. A keyframe that cannot be read is left for get() to report.
  void prefetch(const std::vector<KeyframeRef>& refs, unsigned threads);

  bool contains(const KeyframeRef& ref) const { return entries_.count(toString(ref)) > 0; }
  std::size_t size() const { return entries_.size(); }
  std::size_t capacity() const { return capacity_; }
  std::size_t loads() const { return loads_; }  // keyframes read from files so far

 private:
  Expected<std::shared_ptr<const MapKeyframe>> load(const KeyframeRef& ref) const;  // thread-safe
  void insert(const std::string& key, std::shared_ptr<const MapKeyframe> keyframe);

  std::shared_ptr<const RouteMap> map_;
  RepeatOptions options_;
  std::size_t capacity_;
  std::size_t loads_ = 0;
  std::list<std::string> recency_;  // most recently used first
  struct Entry {
    std::shared_ptr<const MapKeyframe> keyframe;
    std::list<std::string>::iterator position;
  };
  std::unordered_map<std::string, Entry> entries_;
};

}  // namespace homography_teach_repeat
