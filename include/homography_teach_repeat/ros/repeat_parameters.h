// repeat_node's parameters (config/repeat_node.yaml documents each) and its dynamic_reconfigure
// tunables (cfg/Repeat.cfg).
#pragma once

#include <ros/node_handle.h>

#include "homography_teach_repeat/RepeatConfig.h"
#include <optional>

#include "homography_teach_repeat/network/map_relocalizer.h"
#include "homography_teach_repeat/teach_repeat/experience_learning.h"
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"

namespace homography_teach_repeat {

// Throws std::runtime_error naming the bad parameter.
RepeatPipelineOptions readRepeatPipelineOptions(const ros::NodeHandle& nh);
// A map of routes (map_directory): the relocalization's options (relocalization_*). Throws
// std::runtime_error naming the bad parameter.
RelocalizationOptions readRelocalizationOptions(const ros::NodeHandle& nh);
// Routes that learn: the learning options with learn_experiences, nullopt without. Throws
// std::runtime_error naming the bad parameter.
std::optional<ExperienceLearningOptions> readExperienceLearningOptions(const ros::NodeHandle& nh);
// The run-time tunables of RepeatOptions as dynamic_reconfigure reports them.
void writeRepeatTunables(const RepeatOptions& options, RepeatConfig& config);

}  // namespace homography_teach_repeat
