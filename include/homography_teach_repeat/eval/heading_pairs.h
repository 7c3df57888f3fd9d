// Pairs of images of one place with the true horizontal shift between them: the data of
// evaluate_heading_pairs (docs/evaluation.md, "Heading across seasons"). Two layouts:
//  - a GRIEF site folder (gestom/GRIEF; ../shared/realdata/grief_seasonal/<site>):
//    images/MMLL.png (MM visit, LL place, two digits each) and ground_truth/location_L.txt, a table
//    whose entry [r][c] is the shift of visit c+1 against visit r+1 [px] (a scene point at x in
//    visit r+1 appears at x + entry in visit c+1); every pair of visits r < c of a place is a pair;
//  - a list file: one pair a line, `reference_image current_image true_shift_px` (paths absolute
//    or relative to the list's folder); blank lines and lines starting with # are skipped.
// Scoring follows the benchmark (Krajník et al., RAS 2017, Sec. 6): a pair fails when the estimate
// is missing or more than the tolerance (35 px) from the truth.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {
namespace eval {

struct HeadingPair {
  std::string reference_image;  // path
  std::string current_image;    // path
  double true_shift_px = 0.0;   // current x − reference x of the same scene point [px]
  std::string place;            // "3" for GRIEF's place 03; the list file's line number otherwise
};

// The pairs of a GRIEF site folder or a list file. kInvalidInput naming the problem: a path that
// is neither, a folder without images/MMLL.png, a place without its ground-truth table or a table
// too small or with a non-number, a list line without three fields, a shift that is not a number,
// an image that does not exist (the line and path named). No pair at all is kInvalidInput too.
Expected<std::vector<HeadingPair>> readHeadingPairs(const std::string& path);

// The benchmark's verdict on one estimate.
bool headingPairFailed(const std::optional<double>& estimate_px, double true_shift_px, double tolerance_px = 35.0);

}  // namespace eval
}  // namespace homography_teach_repeat
