#include "homography_teach_repeat/ros/homography_node.h"

#include <cv_bridge/cv_bridge.h>
#include <opencv2/imgcodecs.hpp>

#include <stdexcept>

#include "homography_teach_repeat/HomographyStamped.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {
namespace {

RegistrationOptions readRegistrationOptions(const ros::NodeHandle& nh) {
  RegistrationOptions options;
  readParameters(nh, [&] {
    options.features.type = featureTypeFromString(
        readParameter<std::string>(nh, "feature_type", toString(options.features.type)));
    options.features.max_features = readParameter(nh, "max_features", options.features.max_features);
    options.matching.ratio = readParameter(nh, "match_ratio", options.matching.ratio);
    options.matching.mutual = readParameter(nh, "mutual_check", options.matching.mutual);
    options.robust.method =
        robustMethodFromString(readParameter<std::string>(nh, "robust_method",
                                                          toString(options.robust.method)));
    options.robust.inlier_threshold_px =
        readParameter(nh, "inlier_threshold_px", options.robust.inlier_threshold_px);
    options.robust.min_inliers = readParameter(nh, "min_inliers", options.robust.min_inliers);
    options.validate();
  });
  return options;
}

}  // namespace

HomographyNode::HomographyNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      reference_path_(readRequiredParameter<std::string>(private_nh, "reference_image")),
      image_timeout_s_(readParameter(private_nh, "image_timeout", 2.0)),
      registration_(readRegistrationOptions(private_nh)),
      diagnostics_(nh, private_nh) {
  if (!(image_timeout_s_ > 0.0)) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("image_timeout") +
                             "' must be > 0 s");
  }
  const cv::Mat reference = cv::imread(reference_path_, cv::IMREAD_GRAYSCALE);
  if (reference.empty()) {
    throw std::runtime_error("cannot read the reference image '" + reference_path_ +
                             "' (parameter " + private_nh.resolveName("reference_image") + ")");
  }
  const Status reference_status = registration_.setReference(reference);
  if (!reference_status.isOk()) {
    throw std::runtime_error("unusable reference image '" + reference_path_ +
                             "': " + reference_status.toString());
  }
  ROS_INFO("homography_node: reference '%s' with %zu %s features", reference_path_.c_str(),
           registration_.referenceFeatures().keypoints.size(),
           toString(registration_.referenceFeatures().type).c_str());

  homography_publisher_ = private_nh_.advertise<HomographyStamped>("homography", 10);
  debug_image_publisher_ = image_transport::ImageTransport(private_nh_).advertise("debug_image", 1);
  camera_subscriber_ = std::make_unique<CameraSubscription>(
      nh_, private_nh_, "camera/image_raw", 1, "homography_node",
      [this](const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) { onImage(image, info); });
  diagnostics_.setHardwareID("camera");
  diagnostics_.add("registration", this, &HomographyNode::produceDiagnostics);
  // Diagnostics also tick without images, so a stopped camera shows up.
  diagnostics_timer_ =
      nh_.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) { diagnostics_.update(); });
  last_image_time_ = ros::WallTime::now();
}

void HomographyNode::onImage(const sensor_msgs::ImageConstPtr& image,
                             const sensor_msgs::CameraInfoConstPtr& camera_info) {
  last_image_time_ = ros::WallTime::now();
  ++frames_;
  const auto camera = ros_conversions::toPinholeCamera(*camera_info);
  if (!camera) return reportFailure(camera.status());
  const auto cv_image = ros_conversions::toCvImage(image);
  if (!cv_image) return reportFailure(cv_image.status());
  if (cv_image->cols != camera->width() || cv_image->rows != camera->height()) {
    return reportFailure(Status(StatusCode::kInvalidInput,
                                "image size " + std::to_string(cv_image->cols) + "x" +
                                    std::to_string(cv_image->rows) +
                                    " differs from camera_info " + std::to_string(camera->width()) +
                                    "x" + std::to_string(camera->height())));
  }
  const auto result = registration_.registerImage(*cv_image, &camera.value());
  if (!result) return reportFailure(result.status());

  last_status_ = Status::ok();
  last_inliers_ = static_cast<unsigned>(result->homography.inliers.size());
  homography_publisher_.publish(ros_conversions::toMsg(result->homography,
                                                       static_cast<int>(result->matches.size()),
                                                       image->header, reference_path_));
  if (debug_image_publisher_.getNumSubscribers() > 0) {
    debug_image_publisher_.publish(
        cv_bridge::CvImage(image->header, "bgr8",
                           drawRegistration(*cv_image, *result, registration_.referenceSize()))
            .toImageMsg());
  }
  diagnostics_.update();
}

void HomographyNode::reportFailure(const Status& status) {
  ++failures_;
  last_status_ = status;
  last_inliers_ = 0;
  ROS_ERROR_THROTTLE(1.0, "homography_node: frame rejected: %s", status.toString().c_str());
  diagnostics_.force_update();
}

void HomographyNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const double age = (ros::WallTime::now() - last_image_time_).toSec();
  if (age > image_timeout_s_) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "no image for %.1f s", age);
  } else if (last_status_.isOk()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "registering");
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::ERROR, last_status_.toString());
  }
  if (camera_subscriber_) camera_subscriber_->addDiagnostics(stat);
  stat.add("reference", reference_path_);
  stat.add("frames", frames_);
  stat.add("failures", failures_);
  stat.add("last inliers", last_inliers_);
  stat.add("seconds since last image", age);
}

}  // namespace homography_teach_repeat
