// hf::read_color_image: the sources' one way to read a frame. Whatever path it takes inside (libjpeg straight
// into BGR rows, or OpenCV's decoders), the pixels are OpenCV's, and every bad file names itself.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/error.hpp"
#include "hazardforge/image_file.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;

// Colour ramps with fine noise and odd sizes: chroma upsampling, the last partial MCU row and the channel
// order all show in the decoded pixels.
cv::Mat test_picture(cv::Size size) {
  cv::Mat img(size, CV_8UC3);
  cv::RNG rng(7);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      img.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(255 * x / img.cols + rng.uniform(-9, 9)),
                                          cv::saturate_cast<uchar>(40 + 150 * y / img.rows),
                                          cv::saturate_cast<uchar>(230 - 200 * x / img.cols));
  cv::circle(img, {size.width / 3, size.height / 2}, size.height / 4, cv::Scalar(20, 200, 240), -1);
  return img;
}

std::vector<unsigned char> bytes_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& file, const std::vector<unsigned char>& b) {
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

std::string error_of(const fs::path& file, const std::string& what) {
  try {
    hf::read_color_image(file, what);
  } catch (const hf::Error& e) {
    return e.what();
  }
  return "";
}

void expect_as_opencv_reads_it(const fs::path& file) {
  const cv::Mat ref = cv::imread(file.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(ref.empty()) << file;
  const cv::Mat got = hf::read_color_image(file, "image '" + file.string() + "'");
  ASSERT_EQ(got.type(), CV_8UC3) << file;
  ASSERT_EQ(got.size(), ref.size()) << file;
  EXPECT_EQ(cv::norm(got, ref, cv::NORM_INF), 0.0) << file;
}

TEST(ReadColorImage, GivesOpenCvsPixelsForEveryKindOfFrameFile) {
  hf::test::TempDir dir;
  const cv::Mat img = test_picture({203, 117});
  cv::imwrite((dir / "baseline_420.jpg").string(), img, {cv::IMWRITE_JPEG_QUALITY, 90});
  cv::imwrite((dir / "optimised_restarts.jpg").string(), img,
              {cv::IMWRITE_JPEG_QUALITY, 97, cv::IMWRITE_JPEG_OPTIMIZE, 1, cv::IMWRITE_JPEG_RST_INTERVAL, 3});
  cv::imwrite((dir / "progressive.jpg").string(), img, {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  cv::Mat grey;
  cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  cv::imwrite((dir / "grey.jpg").string(), grey);
  cv::imwrite((dir / "frame.png").string(), img);
  for (const char* name :
       {"baseline_420.jpg", "optimised_restarts.jpg", "progressive.jpg", "grey.jpg", "frame.png"})
    expect_as_opencv_reads_it(dir / name);
  // Not merely OpenCV agreeing with itself: the colour frames are the written picture, in BGR order.
  const cv::Mat back = hf::read_color_image(dir / "optimised_restarts.jpg", "frame");
  EXPECT_LT(cv::norm(back, img, cv::NORM_L1) / static_cast<double>(img.total() * 3), 4.0);
}

// A camera's JPEG that says "rotate by 90 degrees" (EXIF orientation 6) is turned as OpenCV turns it.
TEST(ReadColorImage, AppliesTheExifOrientationAsOpenCvDoes) {
  hf::test::TempDir dir;
  const cv::Mat img = test_picture({160, 96});
  cv::imwrite((dir / "plain.jpg").string(), img);
  std::vector<unsigned char> b = bytes_of(dir / "plain.jpg");
  // APP1: "Exif\0\0", a big-endian TIFF header, one IFD entry (0x0112 orientation, SHORT, 1, value 6).
  // clang-format off
  const std::vector<unsigned char> app1 = {
      0xFF, 0xE1, 0x00, 0x22,                                                  // APP1, 34 bytes
      'E', 'x', 'i', 'f', 0x00, 0x00,
      'M', 'M', 0x00, 0x2A, 0x00, 0x00, 0x00, 0x08,                            // TIFF header, IFD at 8
      0x00, 0x01,                                                              // one entry:
      0x01, 0x12, 0x00, 0x03, 0x00, 0x00, 0x00, 0x01, 0x00, 0x06, 0x00, 0x00,  // orientation = 6
      0x00, 0x00, 0x00, 0x00};                                                 // no next IFD
  // clang-format on
  b.insert(b.begin() + 2, app1.begin(), app1.end());
  write_bytes(dir / "rotated.jpg", b);
  expect_as_opencv_reads_it(dir / "rotated.jpg");
  EXPECT_EQ(hf::read_color_image(dir / "rotated.jpg", "frame").size(), cv::Size(96, 160));
}

TEST(ReadColorImage, ABadFileNamesItself) {
  hf::test::TempDir dir;
  cv::imwrite((dir / "whole.jpg").string(), test_picture({120, 80}));
  std::vector<unsigned char> b = bytes_of(dir / "whole.jpg");
  write_bytes(dir / "cut.jpg",
              std::vector<unsigned char>(b.begin(), b.begin() + static_cast<long>(b.size() / 2)));
  EXPECT_EQ(error_of(dir / "cut.jpg", "image 'cut.jpg' (frame 3)"),
            "image 'cut.jpg' (frame 3) is truncated: the JPEG has no end-of-image marker (the decoder would "
            "fill the rest with grey)");
  std::ofstream(dir / "broken.jpg") << "broken";
  EXPECT_EQ(error_of(dir / "broken.jpg", "image 'broken.jpg'"), "image 'broken.jpg' cannot be decoded");
  EXPECT_EQ(error_of(dir / "missing.jpg", "image 'missing.jpg'"), "image 'missing.jpg' cannot be read");
  // Scrambled entropy-coded data with the end marker intact: whatever OpenCV makes of it (its corrupt-data
  // warning and a partly wrong picture), this reads the same.
  for (size_t i = b.size() / 2; i < b.size() / 2 + 40; ++i) b[i] = static_cast<unsigned char>(b[i] ^ 0x5A);
  write_bytes(dir / "scrambled.jpg", b);
  const cv::Mat ref = cv::imread((dir / "scrambled.jpg").string(), cv::IMREAD_COLOR);
  if (ref.empty()) {
    EXPECT_EQ(error_of(dir / "scrambled.jpg", "image"), "image cannot be decoded");
  } else {
    expect_as_opencv_reads_it(dir / "scrambled.jpg");
  }
}

}  // namespace
