#include "homography_teach_repeat/network/route_graph.h"

#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/dijkstra_shortest_paths.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace homography_teach_repeat {
namespace {

struct EdgeData {
  double cost = 0.0;
  double length = 0.0;
  bool junction = false;
};
using Graph = boost::adjacency_list<boost::vecS, boost::vecS, boost::directedS, boost::no_property, EdgeData>;
using Vertex = boost::graph_traits<Graph>::vertex_descriptor;

double headingChange(const Pose2D& a, const Pose2D& b) { return std::abs(a.inverse().compose(b).yaw); }

}  // namespace

struct RouteGraph::Impl {
  Graph graph;
  std::vector<KeyframeRef> refs;                 // per vertex
  std::map<std::pair<std::string, int>, Vertex> vertex_of;  // (route, keyframe index) -> vertex
  double turn_cost = 0.0;

  void addEdge(Vertex a, Vertex b, double length, double turn, bool junction) {
    boost::add_edge(a, b, EdgeData{length + turn_cost * turn, length, junction}, graph);
  }
};

RouteGraph::RouteGraph(const RouteMap& map, const RouteGraphOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& g = *impl_;
  g.turn_cost = options.turn_cost;
  for (const MapRoute& r : map.routes) {
    const auto& keyframes = r.route.keyframes;
    Vertex previous = 0;
    for (std::size_t k = 0; k < keyframes.size(); ++k) {
      const Vertex v = boost::add_vertex(g.graph);
      g.refs.push_back(KeyframeRef{r.name, keyframes[k].index});
      g.vertex_of[{r.name, keyframes[k].index}] = v;
      if (k > 0) {
        const Pose2D& a = keyframes[k - 1].pose;
        const Pose2D& b = keyframes[k].pose;
        g.addEdge(previous, v, std::hypot(b.x - a.x, b.y - a.y), headingChange(a, b), false);
      }
      previous = v;
    }
    if (isClosedRoute(r.route, options.closed_route_gap)) {
      const Pose2D& a = keyframes.back().pose;
      const Pose2D& b = keyframes.front().pose;
      g.addEdge(g.vertex_of[{r.name, keyframes.back().index}], g.vertex_of[{r.name, keyframes.front().index}],
                std::hypot(b.x - a.x, b.y - a.y), headingChange(a, b), false);
    }
  }
  for (const Junction& j : map.junctions) {
    const auto from = g.vertex_of.find({j.from.route, j.from.keyframe});
    const auto to = g.vertex_of.find({j.to.route, j.to.keyframe});
    if (from == g.vertex_of.end() || to == g.vertex_of.end()) continue;  // a loaded map has none such
    const double length = std::hypot(j.to_in_from.x, j.to_in_from.y);
    const double turn = std::abs(j.to_in_from.yaw);
    g.addEdge(from->second, to->second, length, turn, true);
    g.addEdge(to->second, from->second, length, turn, true);
  }
}

RouteGraph::~RouteGraph() = default;
RouteGraph::RouteGraph(RouteGraph&&) noexcept = default;
RouteGraph& RouteGraph::operator=(RouteGraph&&) noexcept = default;

std::size_t RouteGraph::vertexCount() const { return boost::num_vertices(impl_->graph); }
std::size_t RouteGraph::edgeCount() const { return boost::num_edges(impl_->graph); }

Expected<NetworkPath> RouteGraph::shortestPath(const KeyframeRef& from, const KeyframeRef& to) const {
  const Impl& g = *impl_;
  const auto start = g.vertex_of.find({from.route, from.keyframe});
  if (start == g.vertex_of.end()) {
    return Status(StatusCode::kInvalidInput, "start " + toString(from) + " is not a keyframe of the map");
  }
  const auto goal = g.vertex_of.find({to.route, to.keyframe});
  if (goal == g.vertex_of.end()) {
    return Status(StatusCode::kInvalidInput, "destination " + toString(to) + " is not a keyframe of the map");
  }
  const std::size_t n = boost::num_vertices(g.graph);
  std::vector<Vertex> predecessor(n);
  std::vector<double> distance(n, std::numeric_limits<double>::infinity());
  boost::dijkstra_shortest_paths(
      g.graph, start->second,
      boost::predecessor_map(boost::make_iterator_property_map(predecessor.begin(), boost::get(boost::vertex_index, g.graph)))
          .distance_map(boost::make_iterator_property_map(distance.begin(), boost::get(boost::vertex_index, g.graph)))
          .weight_map(boost::get(&EdgeData::cost, g.graph))
          .distance_inf(std::numeric_limits<double>::infinity()));
  if (!std::isfinite(distance[goal->second])) {
    return Status(StatusCode::kNoConsensus, "destination " + toString(to) + " is not reachable from " + toString(from) +
                                                " (routes are repeated forwards only; no junction leads there)");
  }
  std::vector<Vertex> vertices;
  for (Vertex v = goal->second;; v = predecessor[v]) {
    vertices.push_back(v);
    if (v == start->second || predecessor[v] == v) break;
  }
  std::reverse(vertices.begin(), vertices.end());
  NetworkPath path;
  path.cost = distance[goal->second];
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    path.keyframes.push_back(g.refs[vertices[i]]);
    if (i == 0) continue;
    // The cheapest edge between the two (parallel edges are possible: a junction beside a step).
    double best = std::numeric_limits<double>::infinity();
    const EdgeData* chosen = nullptr;
    for (auto [e, end] = boost::out_edges(vertices[i - 1], g.graph); e != end; ++e) {
      if (boost::target(*e, g.graph) != vertices[i]) continue;
      const EdgeData& data = g.graph[*e];
      if (data.cost < best) {
        best = data.cost;
        chosen = &data;
      }
    }
    if (chosen != nullptr) {
      path.length_m += chosen->length;
      if (chosen->junction) ++path.junctions_crossed;
    }
  }
  return path;
}

}  // namespace homography_teach_repeat
