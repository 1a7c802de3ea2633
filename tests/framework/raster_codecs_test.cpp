// PNG files written with libpng (framework/io/raster_codecs.h): the pixels OpenCV reads back
// are exactly the ones written, in every layout the figures and 2D images use, and the header
// says what they are (an RGB file for BGR pixels, 16 bits for 16-bit grey).
#include "framework/io/raster_codecs.h"

#include "tests/framework/io_test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <string>

namespace dsnake {
namespace {

using namespace test_support;  // tests/framework/io_test_support.h

// A pattern with every value of the type's low byte and distinct channels, so that a swapped
// channel, byte or row shows.
cv::Mat pattern(int type, int rows, int cols) {
  cv::Mat m(rows, cols, type);
  const int channels = m.channels();
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x)
      for (int c = 0; c < channels; ++c) {
        const int v = (y * 131 + x * 17 + c * 71) % 256;
        if (m.depth() == CV_16U)
          m.ptr<uint16_t>(y)[x * channels + c] = uint16_t(v * 257 + y);  // both bytes vary
        else
          m.ptr<uint8_t>(y)[x * channels + c] = uint8_t(v);
      }
  return m;
}

bool same_pixels(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0;
}

TEST(RasterCodecs, PngFilesHoldExactlyThePixelsWritten) {
  const std::string dir = fresh_dir();
  struct Case {
    int type;
    int bit_depth, colour_type;  // as the IHDR chunk states them
  };
  for (const Case c : {Case{CV_8UC1, 8, 0}, Case{CV_8UC3, 8, 2}, Case{CV_16UC1, 16, 0}}) {
    const cv::Mat image = pattern(c.type, 37, 53);
    const std::string path = dir + "/p" + std::to_string(c.type) + ".png";
    ASSERT_TRUE(write_raster(path, image)) << path;
    const cv::Mat back = cv::imread(path, cv::IMREAD_UNCHANGED);
    EXPECT_TRUE(same_pixels(image, back)) << "type " << c.type;
    // OpenCV's own encoder, for comparison: the same pixels.
    const std::string theirs = dir + "/q" + std::to_string(c.type) + ".png";
    ASSERT_TRUE(cv::imwrite(theirs, image));
    EXPECT_TRUE(same_pixels(cv::imread(theirs, cv::IMREAD_UNCHANGED), back)) << "type " << c.type;
    // The signature, then IHDR: width and height (big-endian), bit depth, colour type.
    const std::string b = read_file(path);
    ASSERT_GE(b.size(), 26u);
    EXPECT_EQ(b.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_EQ(b.substr(12, 4), "IHDR");
    EXPECT_EQ((uint8_t(b[18]) << 8) | uint8_t(b[19]), 53);
    EXPECT_EQ((uint8_t(b[22]) << 8) | uint8_t(b[23]), 37);
    EXPECT_EQ(int(uint8_t(b[24])), c.bit_depth);
    EXPECT_EQ(int(uint8_t(b[25])), c.colour_type);
  }
  // The extension in any case; BGR pixels come back as BGR.
  const cv::Mat red(4, 6, CV_8UC3, cv::Scalar(0, 0, 255));
  ASSERT_TRUE(write_raster(dir + "/red.PNG", red));
  const cv::Mat back = cv::imread(dir + "/red.PNG", cv::IMREAD_COLOR);
  ASSERT_FALSE(back.empty());
  EXPECT_EQ(back.at<cv::Vec3b>(2, 3), cv::Vec3b(0, 0, 255));
}

TEST(RasterCodecs, AnUnwritablePngIsFalseAndLeavesNoFile) {
  const std::string dir = fresh_dir();
  EXPECT_FALSE(write_raster(dir + "/no/such/folder/p.png", pattern(CV_8UC1, 3, 3)));
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

}  // namespace
}  // namespace dsnake
