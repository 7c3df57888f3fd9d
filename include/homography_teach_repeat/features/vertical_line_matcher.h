// Matching of vertical lines between a reference and a current image (paper 002 §2, after [10]):
// weighted nearest neighbour on brightness and geometric parameters, polarity consistent (the two
// polarities never match), with a mutual-consistency check and a distinctiveness (ratio) test.
//
// Distance of two lines of the same polarity (each term normalised by its scale):
//   D² = (Δx/σx)² + (Δy_mid/σy)² + (Δlength/(σl·max length))² + (Δleft/σb)² + (Δright/σb)²
// Candidates need |Δx| <= max_disparity_px. The robust 1D homography removes what this lets
// through.
#pragma once

#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace homography_teach_repeat {

struct LineMatchOptions {
  double max_disparity_px = 200.0;  // largest |Δx| between matched lines
  double sigma_x_px = 60.0;
  double sigma_y_px = 40.0;          // of the mid-point row
  double sigma_length_ratio = 0.5;   // relative length difference
  double sigma_brightness = 20.0;    // grey levels
  double max_distance = 3.0;         // D above this is no match
  double ratio = 0.9;                // best D must be below ratio × second best (same polarity)
  bool mutual = true;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct LineMatch {
  int reference = -1;
  int current = -1;
  double distance = 0.0;
};

// Status: kInvalidInput (non-finite line x). Empty inputs give an empty match list.
Expected<std::vector<LineMatch>> matchVerticalLines(const std::vector<VerticalLine>& reference,
                                                    const std::vector<VerticalLine>& current,
                                                    const LineMatchOptions& options = {});

}  // namespace homography_teach_repeat
