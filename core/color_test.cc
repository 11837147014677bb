#include "core/color.h"

#include <gtest/gtest.h>

namespace relit {
namespace {

TEST(Color, SrgbRoundTripAndKnownValues) {
  for (int i = 0; i <= 1000; ++i) {
    const float v = i / 1000.0f;
    EXPECT_NEAR(SrgbToLinear(LinearToSrgb(v)), v, 1e-6f);
    EXPECT_NEAR(Gamma22ToLinear(LinearToGamma22(v)), v, 1e-6f);
  }
  EXPECT_NEAR(SrgbToLinear(0.5f), 0.214041f, 1e-6f);  // IEC 61966-2-1
  EXPECT_NEAR(LinearToSrgb(0.0031308f), 0.04045f, 1e-6f);
  EXPECT_NEAR(Gamma22ToLinear(0.5f), 0.217638f, 1e-6f);
}

TEST(Color, EncodeLeavesAlphaLinear) {
  Image image(1, 1, 4);
  image.at(0, 0, 0) = 0.5f;
  image.at(0, 0, 3) = 0.5f;
  const Image encoded = EncodeImage(image, TransferFunction::kSrgb);
  EXPECT_NEAR(encoded.at(0, 0, 0), LinearToSrgb(0.5f), 1e-7f);
  EXPECT_EQ(encoded.at(0, 0, 3), 0.5f);
  EXPECT_EQ(ParseTransferFunction("gamma2.2"), TransferFunction::kGamma22);
  EXPECT_THROW(ParseTransferFunction("hlg"), std::runtime_error);
}

}  // namespace
}  // namespace relit
