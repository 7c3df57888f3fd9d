// Command line and JSON output shared by the evaluation programs: `--key value` arguments with
// defaults, a usage text on --help, a clear error (exit 2) on an unknown key or a bad number.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>
#include <algorithm>

namespace homography_teach_repeat {
namespace cli {

class Arguments {
 public:
  Arguments(std::string program, std::map<std::string, std::string> defaults, std::string usage)
      : program_(std::move(program)), values_(std::move(defaults)), usage_(std::move(usage)) {}

  void parse(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
      const std::string key = argv[i];
      if (key == "--help" || key == "-h") {
        std::cout << "usage: " << program_ << " " << usage_ << "\n";
        std::exit(0);
      }
      if (key.rfind("--", 0) != 0 || i + 1 >= argc || values_.count(key.substr(2)) == 0) {
        fail("unknown or incomplete argument '" + key + "' (see --help)");
      }
      values_[key.substr(2)] = argv[++i];
    }
  }

  const std::string& text(const std::string& key) const { return values_.at(key); }
  int integer(const std::string& key) const {
    try {
      return std::stoi(values_.at(key));
    } catch (const std::exception&) {
      fail("--" + key + " needs an integer, got '" + values_.at(key) + "'");
    }
  }
  double number(const std::string& key) const {
    try {
      return std::stod(values_.at(key));
    } catch (const std::exception&) {
      fail("--" + key + " needs a number, got '" + values_.at(key) + "'");
    }
  }

  // A comma-separated list of integers ("0,2,4"), each in [0, limit); empty text: `fallback`.
  std::vector<int> indices(const std::string& key, int limit, std::vector<int> fallback) const {
    const std::string& text = values_.at(key);
    if (text.empty()) return fallback;
    std::vector<int> result;
    std::size_t start = 0;
    while (start <= text.size()) {
      const std::size_t end = std::min(text.find(',', start), text.size());
      const std::string item = text.substr(start, end - start);
      std::size_t used = 0;
      int value = -1;
      try {
        value = std::stoi(item, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      std::string problem = "--" + key;
      if (used == 0 || used != item.size()) {
        problem.append(": '").append(item).append("' is not an integer");
        fail(problem);
      }
      if (value < 0 || value >= limit) {
        problem.append(": index ").append(item).append(" is outside 0..");
        problem.append(std::to_string(limit - 1));
        fail(problem);
      }
      result.push_back(value);
      start = end + 1;
    }
    return result;
  }

  [[noreturn]] void fail(const std::string& message) const {
    std::cerr << program_ << ": " << message << "\n";
    std::exit(2);
  }

  // Writes `document` to the path of --json when one was given.
  void writeJson(const nlohmann::json& document) const {
    const auto it = values_.find("json");
    if (it == values_.end() || it->second.empty()) return;
    std::ofstream out(it->second);
    out << document.dump(2) << "\n";
    if (!out) fail("cannot write '" + it->second + "'");
    std::cout << "wrote " << it->second << "\n";
  }

 private:
  std::string program_;
  std::map<std::string, std::string> values_;
  std::string usage_;
};

}  // namespace cli
}  // namespace homography_teach_repeat
