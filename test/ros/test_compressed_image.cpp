// ros_conversions::decompress (ros/compressed_image.h): what a compressed camera stream carries,
// decoded to the Image the nodes take; what cannot be decoded refused with the reason.
#include <gtest/gtest.h>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <string>
#include <vector>

#include "homography_teach_repeat/ros/compressed_image.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "support/test_images.h"

namespace htr = homography_teach_repeat;
using htr::ros_conversions::decompress;

namespace {

sensor_msgs::CompressedImage compress(const cv::Mat& image, const std::string& extension, const std::string& format,
                                      const std::vector<int>& parameters = {}) {
  sensor_msgs::CompressedImage message;
  message.header.stamp = ros::Time(12.5);
  message.header.frame_id = "camera_optical_frame";
  message.format = format;
  EXPECT_TRUE(cv::imencode(extension, image, message.data, parameters));
  return message;
}

double meanAbsoluteDifference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  return cv::mean(difference)[0];
}

const cv::Mat& texture() {
  static const cv::Mat image = htr::test_support::makeTexture(160, 120, 3);
  return image;
}

}  // namespace

TEST(CompressedImage, JpegMonoDecodesToMono8WithTheHeader) {
  for (const std::string format : {"jpeg", "mono8; jpeg compressed mono8"}) {
    const auto image = decompress(compress(texture(), ".jpg", format, {cv::IMWRITE_JPEG_QUALITY, 95}));
    ASSERT_TRUE(image) << image.status().toString();
    EXPECT_EQ((*image)->encoding, sensor_msgs::image_encodings::MONO8);
    EXPECT_EQ((*image)->width, 160u);
    EXPECT_EQ((*image)->height, 120u);
    EXPECT_EQ((*image)->header.frame_id, "camera_optical_frame");
    EXPECT_DOUBLE_EQ((*image)->header.stamp.toSec(), 12.5);
    const auto mat = htr::ros_conversions::toCvImage(*image);
    ASSERT_TRUE(mat);
    EXPECT_LT(meanAbsoluteDifference(*mat, texture()), 3.0);  // JPEG at quality 95
  }
}

TEST(CompressedImage, JpegColourDecodesToBgr8InBgrOrder) {
  cv::Mat colour(60, 80, CV_8UC3, cv::Scalar(200, 40, 10));  // B, G, R
  const auto image = decompress(compress(colour, ".jpg", "bgr8; jpeg compressed bgr8", {cv::IMWRITE_JPEG_QUALITY, 95}));
  ASSERT_TRUE(image) << image.status().toString();
  EXPECT_EQ((*image)->encoding, sensor_msgs::image_encodings::BGR8);
  const cv::Mat decoded = cv_bridge::toCvShare(*image)->image;
  const cv::Scalar mean = cv::mean(decoded);
  EXPECT_NEAR(mean[0], 200, 4);
  EXPECT_NEAR(mean[1], 40, 4);
  EXPECT_NEAR(mean[2], 10, 4);
}

TEST(CompressedImage, PngIsLosslessAndSixteenBitsAndAlphaBecomeEightBitBgr) {
  const auto mono = decompress(compress(texture(), ".png", "png"));
  ASSERT_TRUE(mono) << mono.status().toString();
  EXPECT_EQ(meanAbsoluteDifference(cv_bridge::toCvShare(*mono)->image, texture()), 0.0);

  cv::Mat sixteen;
  texture().convertTo(sixteen, CV_16U, 256.0);
  const auto scaled = decompress(compress(sixteen, ".png", "mono16; png compressed mono16"));
  ASSERT_TRUE(scaled) << scaled.status().toString();
  EXPECT_EQ((*scaled)->encoding, sensor_msgs::image_encodings::MONO8);
  EXPECT_EQ(meanAbsoluteDifference(cv_bridge::toCvShare(*scaled)->image, texture()), 0.0);

  cv::Mat bgra(40, 50, CV_8UC4, cv::Scalar(1, 2, 3, 255));
  const auto without_alpha = decompress(compress(bgra, ".png", "bgra8; png compressed bgra8"));
  ASSERT_TRUE(without_alpha) << without_alpha.status().toString();
  EXPECT_EQ((*without_alpha)->encoding, sensor_msgs::image_encodings::BGR8);
}

TEST(CompressedImage, ATruncatedJpegIsRefusedNotFilledWithGrey) {
  sensor_msgs::CompressedImage message = compress(texture(), ".jpg", "jpeg");
  message.data.resize(message.data.size() * 2 / 3);  // libjpeg alone would decode this with grey rows
  const auto image = decompress(message);
  ASSERT_FALSE(image);
  EXPECT_EQ(image.status().code(), htr::StatusCode::kInvalidInput);
  EXPECT_NE(image.status().message().find("truncated JPEG"), std::string::npos) << image.status().message();
}

TEST(CompressedImage, CorruptOrForeignDataIsRefusedNamingTheFormat) {
  sensor_msgs::CompressedImage png = compress(texture(), ".png", "png");
  png.data[png.data.size() / 2] ^= 0xFF;  // a flipped byte inside the image data: its CRC fails
  EXPECT_FALSE(decompress(png));

  sensor_msgs::CompressedImage garbage;
  garbage.format = "jpeg";
  garbage.data = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  const auto not_jpeg = decompress(garbage);
  ASSERT_FALSE(not_jpeg);
  EXPECT_NE(not_jpeg.status().message().find("format 'jpeg'"), std::string::npos) << not_jpeg.status().message();

  sensor_msgs::CompressedImage empty;
  empty.format = "jpeg";
  EXPECT_FALSE(decompress(empty));

  sensor_msgs::CompressedImage depth = compress(texture(), ".png", "16UC1; compressedDepth png");
  const auto refused = decompress(depth);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.status().message().find("not JPEG or PNG"), std::string::npos) << refused.status().message();

  sensor_msgs::CompressedImage unknown = compress(texture(), ".png", "theora");
  EXPECT_FALSE(decompress(unknown));
}
