#include "homography_teach_repeat/ros/compressed_image.h"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cctype>
#include <string>

namespace homography_teach_repeat {
namespace ros_conversions {
namespace {

Status invalid(const std::string& format, const std::string& what) {
  return Status(StatusCode::kInvalidInput, "compressed image (format '" + format + "'): " + what);
}

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

enum class Codec { kJpeg, kPng, kUnknown };

Codec codecOf(const std::string& format) {
  const std::string f = lowercase(format);
  if (f.find("compresseddepth") != std::string::npos) return Codec::kUnknown;
  // "jpeg", "png", "bgr8; jpeg compressed bgr8", "mono8; png compressed mono8", ...
  if (f.find("jpeg") != std::string::npos || f.find("jpg") != std::string::npos) return Codec::kJpeg;
  if (f.find("png") != std::string::npos) return Codec::kPng;
  return Codec::kUnknown;
}

}  // namespace

Expected<sensor_msgs::ImagePtr> decompress(const sensor_msgs::CompressedImage& compressed) {
  const std::string& format = compressed.format;
  const std::vector<uint8_t>& data = compressed.data;
  if (data.empty()) return invalid(format, "no data");
  const Codec codec = codecOf(format);
  if (codec == Codec::kUnknown) {
    return invalid(format, "not JPEG or PNG (depth images and other codecs are not camera images here)");
  }
  if (codec == Codec::kJpeg) {
    if (data.size() < 4 || data[0] != 0xFF || data[1] != 0xD8) return invalid(format, "not JPEG data (no start-of-image marker)");
    // The end-of-image marker, allowing for padding after it.
    std::size_t end = data.size();
    while (end > 2 && data[end - 1] == 0x00) --end;
    if (!(data[end - 2] == 0xFF && data[end - 1] == 0xD9)) {
      return invalid(format, "truncated JPEG (" + std::to_string(data.size()) + " bytes, no end-of-image marker)");
    }
  } else {
    static const uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    if (data.size() < 8 || !std::equal(kPngSignature, kPngSignature + 8, data.begin())) {
      return invalid(format, "not PNG data (no PNG signature)");
    }
  }
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(cv::Mat(1, static_cast<int>(data.size()), CV_8UC1, const_cast<uint8_t*>(data.data())),
                           cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return invalid(format, std::string("cannot be decoded: ") + e.what());
  }
  if (decoded.empty()) return invalid(format, "cannot be decoded (" + std::to_string(data.size()) + " bytes)");
  if (decoded.depth() == CV_16U) {
    cv::Mat eight_bit;
    decoded.convertTo(eight_bit, CV_8U, 1.0 / 256.0);
    decoded = eight_bit;
  } else if (decoded.depth() != CV_8U) {
    return invalid(format, "decodes to an image that is neither 8 nor 16 bits per channel");
  }
  std::string encoding;
  switch (decoded.channels()) {
    case 1:
      encoding = sensor_msgs::image_encodings::MONO8;
      break;
    case 3:
      encoding = sensor_msgs::image_encodings::BGR8;
      break;
    case 4: {
      cv::Mat bgr;
      cv::cvtColor(decoded, bgr, cv::COLOR_BGRA2BGR);
      decoded = bgr;
      encoding = sensor_msgs::image_encodings::BGR8;
      break;
    }
    default:
      return invalid(format, "decodes to " + std::to_string(decoded.channels()) + " channels");
  }
  return cv_bridge::CvImage(compressed.header, encoding, decoded).toImageMsg();
}

}  // namespace ros_conversions
}  // namespace homography_teach_repeat
