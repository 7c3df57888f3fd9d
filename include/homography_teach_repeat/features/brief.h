// BRIEF (Calonder et al., ECCV 2010): 256 intensity comparisons between pixel pairs of a smoothed
// 48 x 48 patch around each keypoint, a 32-byte binary descriptor matched by Hamming distance;
// upright by construction (the patch is never turned) and at one scale, which is what a ground
// robot revisiting a place needs and what survives seasons best among the descriptors measured
// (docs/evaluation.md, "Heading across seasons"). Keypoints from AGAST corners (OpenCV). Written
// here because Debian's OpenCV lacks xfeatures2d, where OpenCV keeps its BRIEF.
//
// The comparison pairs are drawn once from an isotropic Gaussian (σ = 48/5, clipped to the patch:
// BRIEF's "G II" layout) by cv::RNG with a fixed seed: the same on every machine and in every
// route file. The smoothing is a 9 x 9 Gaussian (σ 2).
#pragma once

#include <opencv2/features2d.hpp>

namespace homography_teach_repeat {

// A cv::Feature2D: detectAndCompute finds AGAST corners (threshold 10, non-maximum suppression),
// keeps the `max_features` strongest and those whose patch lies inside the image, and describes
// them (CV_8U, 32 columns). Accepts 8-bit grey images (FeatureExtractor converts colour).
cv::Ptr<cv::Feature2D> createAgastBrief(int max_features);

}  // namespace homography_teach_repeat
