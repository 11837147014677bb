#include "core/render/texture.h"

#include <cmath>

#include "core/color.h"
#include "core/error.h"

namespace relit::render {

Texture Texture::FromImage(const Image& image, bool srgb) {
  RELIT_REQUIRE(!image.empty(), "texture image is empty");
  auto linear = std::make_shared<Image>(image.width(), image.height(), 3);
  Rgb sum = Rgb::Zero();
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      for (int c = 0; c < 3; ++c) {
        // Grey images replicate their single channel.
        float v = image.at(x, y, std::min(c, image.channels() - 1));
        if (srgb) v = SrgbToLinear(v);
        linear->at(x, y, c) = v;
        sum[c] += v;
      }
    }
  }
  Texture texture(Rgb::Zero());
  texture.image_ = linear;
  texture.average_ = sum / static_cast<float>(image.pixel_count());
  return texture;
}

Texture Texture::FromFile(const std::string& path, bool srgb) {
  return FromImage(ReadImage(path), srgb);
}

Rgb Texture::Eval(const Vec2f& uv) const {
  if (!image_) return constant_;
  const Image& im = *image_;
  // Texel centres at (i + 0.5) / width; v runs up, image rows run down.
  const float x = uv.x() * im.width() - 0.5f;
  const float y = (1.0f - uv.y()) * im.height() - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const float tx = x - fx, ty = y - fy;
  auto wrap = [](int i, int n) { i %= n; return i < 0 ? i + n : i; };
  const int x0 = wrap(static_cast<int>(fx), im.width()), x1 = wrap(x0 + 1, im.width());
  const int y0 = wrap(static_cast<int>(fy), im.height()), y1 = wrap(y0 + 1, im.height());
  Rgb result;
  for (int c = 0; c < 3; ++c) {
    const float top = (1 - tx) * im.at(x0, y0, c) + tx * im.at(x1, y0, c);
    const float bottom = (1 - tx) * im.at(x0, y1, c) + tx * im.at(x1, y1, c);
    result[c] = (1 - ty) * top + ty * bottom;
  }
  return result;
}

Rgb Texture::Average() const { return image_ ? average_ : constant_; }

}  // namespace relit::render
