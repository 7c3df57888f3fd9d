// How a homography's local stretch changes feature matches (docs/route_audit.md, "How well it
// predicts"; docs/math.md §3.4): a SIFT-like keypoint is invariant to a similarity of its patch, not
// to a stretch, so where one view stretches the other's patch its matches are noisier and rarer.
// Used by the route audit to predict a fix beside a keyframe.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <vector>

namespace homography_teach_repeat {

// How much larger than between views that differ by a similarity the error of matches is, where a
// homography H (reference pixel to current pixel) maps `pixels` of the reference: a SIFT-like
// keypoint is invariant to a similarity of its patch, not to a stretch, and is located worse the
// more the other view stretches it. At each pixel the local map is H's 2x2 Jacobian there, its
// stretch a = s1/s2 (its singular values; 1 for a similarity), the noise 1 + gain (a − 1); the
// root mean square over the pixels (the estimator takes one σ). 1 for no pixel or gain 0.
double matchStretchNoiseScale(const Eigen::Matrix3d& H, const std::vector<Eigen::Vector2d>& pixels, double gain);

// The stretch a = s1/s2 ≥ 1 of H's local map at a reference pixel (the singular values of its 2x2
// Jacobian there; 1 for a similarity); nullopt where H sends the pixel to infinity.
std::optional<double> localStretch(const Eigen::Matrix3d& H, const Eigen::Vector2d& pixel);

// The chance that a feature at one of `pixels` matches, over its chance in an unstretched view,
// averaged over the pixels: exp(−decay (a − 1)), a the local stretch of H there (localStretch).
// 1 for no pixel or decay 0.
double matchChanceScale(const Eigen::Matrix3d& H, const std::vector<Eigen::Vector2d>& pixels, double decay);

}  // namespace homography_teach_repeat
