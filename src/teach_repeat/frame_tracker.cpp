#include "homography_teach_repeat/teach_repeat/frame_tracker.h"

#include <opencv2/video/tracking.hpp>

#include <chrono>
#include <exception>
#include <string>
#include <utility>

namespace homography_teach_repeat {

FrameTracker::FrameTracker(int max_tracked_frames, double tolerance_px, int min_points)
    : max_tracked_frames_(max_tracked_frames), tolerance_px_(tolerance_px), min_points_(min_points) {}

bool FrameTracker::canTrack(int keyframe) const {
  return memory_ && memory_->keyframe == keyframe && memory_->frames_tracked < max_tracked_frames_;
}

void FrameTracker::remember(const PointMatches& inliers, int keyframe, const cv::Mat& gray, int frames_tracked) {
  memory_.reset();
  if (max_tracked_frames_ == 0 || gray.empty() || keyframe < 0) return;
  Memory memory;
  memory.image = gray.clone();  // the caller's image may be a view of a buffer it reuses
  memory.keyframe = keyframe;
  memory.frames_tracked = frames_tracked;
  memory.reference.reserve(inliers.size());
  memory.current.reserve(inliers.size());
  for (const PointMatch& m : inliers) {
    memory.reference.emplace_back(static_cast<float>(m.reference.x()), static_cast<float>(m.reference.y()));
    memory.current.emplace_back(static_cast<float>(m.current.x()), static_cast<float>(m.current.y()));
  }
  memory_ = std::move(memory);
}

Expected<PointMatches> FrameTracker::track(const cv::Mat& gray) const {
  if (!memory_) return Status(StatusCode::kNoConsensus, "tracking: no matches to follow");
  // OpenCV's defaults for the window, pyramid and stopping rule: a 21x21 px window over 4 levels
  // (maxLevel 3) follows motions of tens of pixels between frames (a robot turning at 0.5 rad/s
  // moves the image ~8 px per frame at 30 Hz with f = 500 px).
  const cv::Size window(21, 21);
  constexpr int kPyramidLevels = 3;
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  std::vector<cv::Point2f> forward, backward;
  std::vector<unsigned char> forward_found, backward_found;
  std::vector<float> error;
  try {
    cv::calcOpticalFlowPyrLK(memory_->image, gray, memory_->current, forward, forward_found, error, window,
                             kPyramidLevels, stop);
    cv::calcOpticalFlowPyrLK(gray, memory_->image, forward, backward, backward_found, error, window,
                             kPyramidLevels, stop);
  } catch (const cv::Exception& e) {
    return Status(StatusCode::kInvalidInput, std::string("optical flow: ") + e.what());
  }
  const auto inside = [&](const cv::Point2f& p) {
    return p.x >= 0.0F && p.y >= 0.0F && p.x <= static_cast<float>(gray.cols - 1) &&
           p.y <= static_cast<float>(gray.rows - 1);
  };
  PointMatches followed;
  for (std::size_t i = 0; i < forward.size(); ++i) {
    if (!forward_found[i] || !backward_found[i] || !inside(forward[i])) continue;
    if (cv::norm(backward[i] - memory_->current[i]) > tolerance_px_) continue;
    followed.push_back({Eigen::Vector2d(memory_->reference[i].x, memory_->reference[i].y),
                        Eigen::Vector2d(forward[i].x, forward[i].y)});
  }
  if (static_cast<int>(followed.size()) < min_points_) {
    return Status(StatusCode::kNoConsensus, "tracking: " + std::to_string(followed.size()) + " of " +
                                                std::to_string(memory_->current.size()) + " points followed, need " +
                                                std::to_string(min_points_));
  }
  return followed;
}

BackgroundDetection& BackgroundDetection::operator=(BackgroundDetection&& other) noexcept {
  if (this != &other) {
    discard();
    job_ = std::move(other.job_);
    other.job_.reset();
  }
  return *this;
}

void BackgroundDetection::start(Detect detect, const cv::Mat& gray, std::optional<Pose2D> predicted_pose) {
  discard();
  Job job;
  job.gray = gray.clone();  // the caller's image may be a view of a buffer it reuses
  job.predicted_pose = predicted_pose;
  job.observations = std::async(std::launch::async, [detect = std::move(detect), image = job.gray]() {
    try {
      return detect(image);
    } catch (const std::exception& e) {
      return Expected<FrameObservations>(
          Status(StatusCode::kInvalidInput, std::string("background feature detection: ") + e.what()));
    }
  });
  job_ = std::move(job);
}

BackgroundDetection::Result BackgroundDetection::take() {
  const auto start = std::chrono::steady_clock::now();
  Job job = std::move(*job_);
  job_.reset();
  Result result{job.observations.get(), std::move(job.gray), job.predicted_pose, job.frames_since, 0.0};
  result.waited_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void BackgroundDetection::discard() {
  if (!job_) return;
  if (job_->observations.valid()) job_->observations.wait();
  job_.reset();
}

}  // namespace homography_teach_repeat
