// sensor_msgs/CompressedImage -> sensor_msgs/Image, decoded with OpenCV. Debian ships no
// compressed_image_transport plugin, so the nodes and evaluate_sequence decode compressed camera
// streams themselves (docs/using.md, "Compressed camera streams").
#pragma once

#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {
namespace ros_conversions {

// The image of a CompressedImage as compressed_image_transport (or a camera driver) writes it:
// `format` "jpeg", "png", or "<encoding>; jpeg compressed <target>" / "<encoding>; png compressed
// <target>". The result keeps the header and is mono8 (one channel) or bgr8 (colour; an alpha
// channel is dropped, 16-bit PNG is scaled to 8 bits).
// kInvalidInput, naming the format and what is wrong, for: empty data, a format that is not JPEG or
// PNG (compressedDepth, unknown), data whose signature is not the format's, a JPEG without its
// end-of-image marker (a truncated frame: libjpeg would fill the missing rows with grey and report
// nothing), and data OpenCV cannot decode.
Expected<sensor_msgs::ImagePtr> decompress(const sensor_msgs::CompressedImage& compressed);

}  // namespace ros_conversions
}  // namespace homography_teach_repeat
