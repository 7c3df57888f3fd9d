#include "homography_teach_repeat/eval/heading_pairs.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

namespace homography_teach_repeat {
namespace eval {
namespace {

namespace fs = std::filesystem;

Status invalid(const std::string& message) { return Status(StatusCode::kInvalidInput, message); }

// A number that is the whole of `text`.
std::optional<double> parseNumber(const std::string& text) {
  std::size_t used = 0;
  try {
    const double value = std::stod(text, &used);
    if (used == text.size() && std::isfinite(value)) return value;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

// MMLL.png: visit and place with two digits each (both below 100: the file names were parsed so).
std::string imageName(int visit, int place) {
  std::ostringstream name;
  name << std::setfill('0') << std::setw(2) << visit << std::setw(2) << place << ".png";
  return name.str();
}

Expected<std::vector<HeadingPair>> readGriefSite(const fs::path& site) {
  const fs::path images = site / "images";
  std::map<int, std::set<int>> visits_of_place;  // place -> visits
  std::error_code error;
  if (fs::is_directory(images, error)) {
    for (const auto& entry : fs::directory_iterator(images, error)) {
      const std::string file = entry.path().filename().string();  // MMLL.png
      const bool digits = file.size() == 8 && std::all_of(file.begin(), file.begin() + 4, [](char c) {
                            return std::isdigit(static_cast<unsigned char>(c)) != 0;
                          });
      if (digits && file.compare(4, 4, ".png") == 0) {
        visits_of_place[std::stoi(file.substr(2, 2))].insert(std::stoi(file.substr(0, 2)));
      }
    }
  }
  if (visits_of_place.empty()) {
    return invalid("'" + site.string() + "' holds no images/MMLL.png (MM visit, LL place): not a GRIEF site folder");
  }
  std::vector<HeadingPair> pairs;
  for (const auto& [place, visits] : visits_of_place) {
    const fs::path table_path = site / "ground_truth" / ("location_" + std::to_string(place) + ".txt");
    std::ifstream table_file(table_path);
    if (!table_file) return invalid("place " + std::to_string(place) + " has images but no " + table_path.string());
    std::vector<std::vector<double>> table;
    std::string line;
    int line_number = 0;
    while (std::getline(table_file, line)) {
      ++line_number;
      std::istringstream fields(line);
      std::vector<double> row;
      std::string field;
      while (fields >> field) {
        const auto value = parseNumber(field);
        if (!value) {
          return invalid(table_path.string() + " line " + std::to_string(line_number) + ": '" + field +
                         "' is not a number");
        }
        row.push_back(*value);
      }
      if (!row.empty()) table.push_back(row);
    }
    const int last_visit = *visits.rbegin();
    for (const int r : visits) {
      for (const int c : visits) {
        if (c <= r) continue;
        if (static_cast<int>(table.size()) < c ||
            static_cast<int>(table[static_cast<std::size_t>(r - 1)].size()) < c) {
          return invalid(table_path.string() + " has no entry for visits " + std::to_string(r) + " and " +
                         std::to_string(c) + " (a table of at least " + std::to_string(last_visit) + " x " +
                         std::to_string(last_visit) + " expected)");
        }
        pairs.push_back(HeadingPair{(images / imageName(r, place)).string(), (images / imageName(c, place)).string(),
                                    table[static_cast<std::size_t>(r - 1)][static_cast<std::size_t>(c - 1)],
                                    std::to_string(place)});
      }
    }
  }
  if (pairs.empty()) return invalid("'" + site.string() + "' has no place with two visits");
  return pairs;
}

Expected<std::vector<HeadingPair>> readList(const fs::path& list) {
  std::ifstream file(list);
  if (!file) return invalid("cannot read '" + list.string() + "'");
  const fs::path folder = list.parent_path();
  std::vector<HeadingPair> pairs;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    std::istringstream fields(line);
    std::vector<std::string> items;
    std::string item;
    while (fields >> item) items.push_back(item);
    if (items.empty() || items[0][0] == '#') continue;
    const std::string where = list.string() + " line " + std::to_string(line_number);
    if (items.size() != 3) {
      return invalid(where + ": expected `reference_image current_image true_shift_px`, got " +
                     std::to_string(items.size()) + " fields");
    }
    const auto shift = parseNumber(items[2]);
    if (!shift) return invalid(where + ": the shift '" + items[2] + "' is not a number");
    HeadingPair pair;
    for (int i = 0; i < 2; ++i) {
      fs::path image = items[static_cast<std::size_t>(i)];
      if (image.is_relative()) image = folder / image;
      std::error_code error;
      if (!fs::is_regular_file(image, error)) return invalid(where + ": no image '" + image.string() + "'");
      (i == 0 ? pair.reference_image : pair.current_image) = image.string();
    }
    pair.true_shift_px = *shift;
    pair.place = std::to_string(line_number);
    pairs.push_back(pair);
  }
  if (pairs.empty()) return invalid("'" + list.string() + "' lists no pair");
  return pairs;
}

}  // namespace

Expected<std::vector<HeadingPair>> readHeadingPairs(const std::string& path) {
  std::error_code error;
  if (fs::is_directory(path, error)) return readGriefSite(path);
  if (fs::is_regular_file(path, error)) return readList(path);
  return invalid("'" + path + "' is neither a GRIEF site folder nor a list file");
}

bool headingPairFailed(const std::optional<double>& estimate_px, double true_shift_px, double tolerance_px) {
  return !estimate_px || !std::isfinite(*estimate_px) || std::abs(*estimate_px - true_shift_px) > tolerance_px;
}

}  // namespace eval
}  // namespace homography_teach_repeat
