// Textures for material parameters: constants or bilinearly filtered images.
#pragma once

#include <memory>
#include <string>

#include "core/image.h"
#include "core/render/sampling.h"

namespace relit::render {

// UV convention (OBJ): u runs right, v runs *up* the image, wrap = repeat.
class Texture {
 public:
  Texture() : Texture(Rgb(0, 0, 0)) {}
  // Constant value (implicit so Material fields can be set from Rgb).
  Texture(const Rgb& value) : constant_(value) {}  // NOLINT(runtime/explicit)
  template <typename Derived>
  Texture(const Eigen::ArrayBase<Derived>& value) : constant_(value) {}  // NOLINT(runtime/explicit)
  // Image texture; srgb=true decodes 8-bit colour with the sRGB curve.
  static Texture FromImage(const Image& image, bool srgb);
  static Texture FromFile(const std::string& path, bool srgb);

  bool is_constant() const { return image_ == nullptr; }
  const Rgb& constant() const { return constant_; }
  Rgb Eval(const Vec2f& uv) const;
  // Mean over the texture (or the constant): used for sampling weights.
  Rgb Average() const;

 private:
  Rgb constant_;
  std::shared_ptr<const Image> image_;  // linear, 3 channels
  Rgb average_ = Rgb::Zero();
};

}  // namespace relit::render
