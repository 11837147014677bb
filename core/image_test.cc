#include "core/image.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "core/color.h"
#include "core/test_dir.h"

namespace relit {
namespace {

std::string TempPath(const std::string& name) { return test_support::TempPathIn("relit_image_test", name); }

TEST(Image, MultiChannelExrKeepsNamesAndHalfPrecision) {
  Image image(7, 5, std::vector<std::string>{"cue0.R", "cue0.G", "cue0.B", "u", "v"});
  for (size_t i = 0; i < image.data().size(); ++i) image.data()[i] = 0.001f * i + 0.25f;
  const std::string path = TempPath("multi.exr");
  WriteImage(path, image);
  const Image back = ReadImage(path);
  ASSERT_EQ(back.width(), 7);
  ASSERT_EQ(back.height(), 5);
  ASSERT_EQ(back.channels(), 5);
  // Any channel order OpenEXR chooses, the names identify the data.
  for (const std::string& name : image.channel_names()) {
    const int a = image.ChannelIndex(name), b = back.ChannelIndex(name);
    ASSERT_GE(b, 0) << name;
    for (int y = 0; y < 5; ++y) {
      for (int x = 0; x < 7; ++x) {
        EXPECT_NEAR(back.at(x, y, b), image.at(x, y, a), image.at(x, y, a) * 1e-3f);  // half: 11-bit mantissa
      }
    }
  }
}

TEST(Image, Png16RoundTripIsExactToQuantisation) {
  Image image(4, 3, 1);
  for (size_t i = 0; i < image.data().size(); ++i) image.data()[i] = i / 11.0f;
  const std::string path = TempPath("grey16.png");
  WriteImage(path, image, PixelStorage::kUint16);
  const Image back = ReadImage(path);
  for (size_t i = 0; i < image.data().size(); ++i) EXPECT_NEAR(back.data()[i], image.data()[i], 0.5f / 65535.0f + 1e-7f);
}

TEST(Image, Png8ClampsAndQuantises) {
  Image image(2, 1, 3);
  image.at(0, 0, 0) = 2.0f;   // clamps to 1
  image.at(1, 0, 0) = -1.0f;  // clamps to 0
  image.at(0, 0, 1) = 0.5f;
  const std::string path = TempPath("rgb8.png");
  WriteImage(path, image, PixelStorage::kUint8);
  const Image back = ReadImage(path);
  EXPECT_EQ(back.at(0, 0, 0), 1.0f);
  EXPECT_EQ(back.at(1, 0, 0), 0.0f);
  EXPECT_NEAR(back.at(0, 0, 1), 0.5f, 0.5f / 255.0f + 1e-6f);
}

TEST(Image, MissingFileIsClearError) {
  try {
    ReadImage("/nonexistent/x.exr");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/x.exr"), std::string::npos);
  }
}

TEST(Image, MatConversionRoundTrip) {
  Image image(3, 2, 3);
  for (size_t i = 0; i < image.data().size(); ++i) image.data()[i] = float(i);
  const Image back = Image::FromMat(image.ToMat());
  EXPECT_EQ(back.data(), image.data());
}

}  // namespace
}  // namespace relit
