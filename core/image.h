// Float images and file IO through OpenImageIO.
//
// Pixel values are stored as given: IO never applies a transfer function.
// Use the helpers in color.h to encode linear values for 8/16-bit files and to
// decode them again. EXR files are written as half floats by default.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace relit {

class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels, float fill = 0.0f);
  Image(int width, int height, std::vector<std::string> channel_names, float fill = 0.0f);

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return data_.empty(); }
  size_t pixel_count() const { return static_cast<size_t>(width_) * height_; }

  float& at(int x, int y, int c) { return data_[(static_cast<size_t>(y) * width_ + x) * channels_ + c]; }
  float at(int x, int y, int c) const { return data_[(static_cast<size_t>(y) * width_ + x) * channels_ + c]; }
  float* pixel(int x, int y) { return &data_[(static_cast<size_t>(y) * width_ + x) * channels_]; }
  const float* pixel(int x, int y) const { return &data_[(static_cast<size_t>(y) * width_ + x) * channels_]; }

  std::vector<float>& data() { return data_; }
  const std::vector<float>& data() const { return data_; }

  // Channel names, e.g. {"R","G","B","A"} or {"cue0.R", ...}. Defaults to
  // R,G,B,A for up to 4 channels and ch0..chN otherwise.
  const std::vector<std::string>& channel_names() const { return channel_names_; }
  void set_channel_names(std::vector<std::string> names);
  // Index of a channel by name; -1 when absent.
  int ChannelIndex(const std::string& name) const;

  // New image holding the given channels (by index) in that order.
  Image SelectChannels(const std::vector<int>& channels) const;
  // New image holding the named channels; throws when one is missing.
  Image SelectChannels(const std::vector<std::string>& names) const;

  // Conversions to OpenCV (CV_32FC{n}, channel order kept, i.e. RGB not BGR).
  cv::Mat ToMat() const;
  static Image FromMat(const cv::Mat& mat);  // any depth; 8U/16U scaled to [0,1]

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  std::vector<float> data_;
  std::vector<std::string> channel_names_;
};

enum class PixelStorage { kHalf, kFloat, kUint8, kUint16 };

// Reads any OpenImageIO-supported file. Integer formats are scaled to [0, 1];
// no transfer function is undone. Throws relit::Error naming the file.
Image ReadImage(const std::string& path);

// Writes by extension: .exr (half unless kFloat), .png (8-bit unless kUint16),
// .jpg. Values for integer formats are clamped to [0, 1] and rounded.
// The file is written to a temporary name and renamed, so readers never see a
// partial file.
void WriteImage(const std::string& path, const Image& image,
                PixelStorage storage = PixelStorage::kHalf);

}  // namespace relit
