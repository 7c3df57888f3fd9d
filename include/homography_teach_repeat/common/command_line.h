// Command line and JSON output shared by the evaluation programs: `--key value` arguments with
// defaults, a usage text on --help, a clear error (exit 2) on an unknown key or a bad number.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>

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
