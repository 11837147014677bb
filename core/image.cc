#include "core/image.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <OpenImageIO/imageio.h>

#include "core/camera.h"
#include "core/error.h"

namespace relit {

namespace {
std::vector<std::string> DefaultChannelNames(int channels) {
  static const char* kRgba[] = {"R", "G", "B", "A"};
  std::vector<std::string> names;
  for (int c = 0; c < channels; ++c) {
    if (channels == 1) names.push_back("Y");
    else if (channels <= 4) names.push_back(kRgba[c]);
    else names.push_back("ch" + std::to_string(c));
  }
  return names;
}

std::string LowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext;
}
}  // namespace

Image::Image(int width, int height, int channels, float fill)
    : width_(width), height_(height), channels_(channels),
      data_(static_cast<size_t>(width) * height * channels, fill),
      channel_names_(DefaultChannelNames(channels)) {
  RELIT_CHECK(width >= 0 && height >= 0 && channels >= 0);
}

Image::Image(int width, int height, std::vector<std::string> channel_names, float fill)
    : Image(width, height, static_cast<int>(channel_names.size()), fill) {
  channel_names_ = std::move(channel_names);
}

void Image::set_channel_names(std::vector<std::string> names) {
  RELIT_CHECK(static_cast<int>(names.size()) == channels_);
  channel_names_ = std::move(names);
}

int Image::ChannelIndex(const std::string& name) const {
  for (int c = 0; c < channels_; ++c) {
    if (channel_names_[c] == name) return c;
  }
  return -1;
}

Image Image::SelectChannels(const std::vector<int>& channels) const {
  std::vector<std::string> names;
  for (int c : channels) {
    RELIT_CHECK(c >= 0 && c < channels_);
    names.push_back(channel_names_[c]);
  }
  Image out(width_, height_, names);
  const int n = static_cast<int>(channels.size());
  for (size_t i = 0; i < pixel_count(); ++i) {
    for (int k = 0; k < n; ++k) out.data_[i * n + k] = data_[i * channels_ + channels[k]];
  }
  return out;
}

Image Image::SelectChannels(const std::vector<std::string>& names) const {
  std::vector<int> indices;
  for (const std::string& name : names) {
    const int index = ChannelIndex(name);
    RELIT_REQUIRE(index >= 0, "image has no channel '", name, "'");
    indices.push_back(index);
  }
  return SelectChannels(indices);
}

cv::Mat Image::ToMat() const {
  RELIT_CHECK(channels_ >= 1 && channels_ <= CV_CN_MAX);
  cv::Mat mat(height_, width_, CV_32FC(channels_));
  std::copy(data_.begin(), data_.end(), mat.ptr<float>());
  return mat;
}

Image Image::FromMat(const cv::Mat& mat) {
  cv::Mat converted;
  double scale = 1.0;
  if (mat.depth() == CV_8U) scale = 1.0 / 255.0;
  if (mat.depth() == CV_16U) scale = 1.0 / 65535.0;
  mat.convertTo(converted, CV_32F, scale);
  if (!converted.isContinuous()) converted = converted.clone();
  Image image(converted.cols, converted.rows, converted.channels());
  std::copy(converted.ptr<float>(), converted.ptr<float>() + image.data_.size(), image.data_.begin());
  return image;
}

Image ReadImage(const std::string& path) {
  RELIT_REQUIRE(std::filesystem::exists(path), "image file not found: ", path);
  auto input = OIIO::ImageInput::open(path);
  RELIT_REQUIRE(input != nullptr, "cannot read image ", path, ": ", OIIO::geterror());
  const OIIO::ImageSpec& spec = input->spec();
  // A damaged header can claim any size; allocating it would exhaust memory.
  RELIT_REQUIRE(spec.width > 0 && spec.height > 0 && spec.nchannels > 0 && spec.nchannels <= 64 &&
                    spec.width <= kMaxImageSidePx && spec.height <= kMaxImageSidePx &&
                    static_cast<int64_t>(spec.width) * spec.height <= kMaxImagePixels,
                "cannot read image ", path, ": its header claims ", spec.width, "x", spec.height, " pixels, ",
                spec.nchannels, " channels, more than relit reads (the file may be damaged; regenerate it)");
  Image image(spec.width, spec.height, spec.nchannels);
  std::vector<std::string> names(spec.channelnames.begin(), spec.channelnames.end());
  if (static_cast<int>(names.size()) == spec.nchannels) image.set_channel_names(names);
  const bool ok = input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT,
                                    image.data().data());
  RELIT_REQUIRE(ok, "cannot decode image ", path, ": ", input->geterror(),
                " (the file may be truncated; regenerate it)");
  input->close();
  return image;
}

void WriteImage(const std::string& path, const Image& image, PixelStorage storage) {
  RELIT_REQUIRE(!image.empty(), "refusing to write an empty image to ", path);
  const std::string ext = LowerExtension(path);
  OIIO::TypeDesc type = OIIO::TypeDesc::HALF;
  if (ext == ".exr") {
    type = storage == PixelStorage::kFloat ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::HALF;
  } else if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") {
    type = (storage == PixelStorage::kUint16 && ext == ".png") ? OIIO::TypeDesc::UINT16
                                                                : OIIO::TypeDesc::UINT8;
  } else {
    Fail("unsupported image extension '", ext, "' for ", path, " (use .exr, .png or .jpg)");
  }
  OIIO::ImageSpec spec(image.width(), image.height(), image.channels(), type);
  spec.channelnames.assign(image.channel_names().begin(), image.channel_names().end());
  if (ext == ".exr") spec.attribute("compression", "zip");
  // OpenImageIO stamps the current time by default; reruns must give identical bytes.
  spec.attribute("DateTime", "");
  const int alpha = image.ChannelIndex("A");
  spec.alpha_channel = alpha;

  // Integer formats: clamp so out-of-range linear values do not wrap.
  const float* pixels = image.data().data();
  std::vector<float> clamped;
  if (type != OIIO::TypeDesc::HALF && type != OIIO::TypeDesc::FLOAT) {
    clamped.resize(image.data().size());
    for (size_t i = 0; i < clamped.size(); ++i) {
      const float v = image.data()[i];
      clamped[i] = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
    }
    pixels = clamped.data();
  }

  const std::filesystem::path target(path);
  if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path());
  // Keep the extension on the temporary file: OIIO picks the format from it.
  const std::string temp = (target.parent_path() / (".tmp-" + target.filename().string())).string();
  auto output = OIIO::ImageOutput::create(temp);
  RELIT_REQUIRE(output != nullptr, "cannot create image writer for ", path, ": ", OIIO::geterror());
  RELIT_REQUIRE(output->open(temp, spec), "cannot open ", temp, " for writing: ", output->geterror());
  const bool ok = output->write_image(OIIO::TypeDesc::FLOAT, pixels);
  output->close();
  if (!ok) {
    std::filesystem::remove(temp);
    Fail("cannot write image ", path, ": ", output->geterror());
  }
  std::filesystem::rename(temp, target);
}

}  // namespace relit
