// The evaluation programs draw their PNGs with scripts/plot_evaluation (matplotlib) from the JSON
// they wrote; this finds the script (the source tree's, or the one installed next to the program).
#pragma once

#include <string>

namespace homography_teach_repeat {
namespace eval {

// Runs plot_evaluation on `json_path`; its exit code, or 1 (with a message naming `program`) when
// the script is not found.
int drawPlots(const std::string& json_path, const std::string& program);

}  // namespace eval
}  // namespace homography_teach_repeat
