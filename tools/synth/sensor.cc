#include "tools/synth/sensor.h"

#include <algorithm>
#include <cmath>

#include "core/color.h"
#include "core/error.h"
#include "core/render/sampling.h"

namespace relit::synth {

void SensorParams::Check() const {
  RELIT_REQUIRE(exposure > 0 && std::isfinite(exposure), "sensor exposure must be positive, got ",
                exposure);
  RELIT_REQUIRE(full_well_e >= 10 && full_well_e <= 1e6,
                "sensor full_well_e must be in [10, 1e6] electrons, got ", full_well_e);
  RELIT_REQUIRE(read_noise_e >= 0 && read_noise_e <= 100,
                "sensor read_noise_e must be in [0, 100] electrons, got ", read_noise_e);
}

std::vector<uint8_t> SensorCapture(const Image& radiance, const SensorParams& params,
                                   uint64_t seed, uint64_t stream) {
  params.Check();
  RELIT_CHECK(radiance.channels() >= 3);
  render::Rng rng(render::MixBits(seed), stream);
  auto normal = [&rng]() {
    const float u1 = 1.0f - rng.Uniform(), u2 = rng.Uniform();
    return std::sqrt(-2.0f * std::log(u1)) * std::cos(2.0f * render::kPi * u2);
  };
  auto poisson = [&](double mean) {
    if (mean > 20) return std::max(0.0, mean + std::sqrt(mean) * normal());
    // Knuth's method for small means.
    const double limit = std::exp(-mean);
    double product = rng.Uniform();
    int k = 0;
    while (product > limit) {
      ++k;
      product *= rng.Uniform();
    }
    return static_cast<double>(k);
  };
  std::vector<uint8_t> out(radiance.pixel_count() * 3);
  size_t i = 0;
  for (int y = 0; y < radiance.height(); ++y) {
    for (int x = 0; x < radiance.width(); ++x) {
      for (int c = 0; c < 3; ++c) {
        const double signal =
            std::clamp(params.exposure * radiance.at(x, y, c), 0.0, 1.0) * params.full_well_e;
        const double electrons = poisson(signal) + params.read_noise_e * normal();
        const double linear = std::clamp(electrons / params.full_well_e, 0.0, 1.0);
        const double encoded = LinearToSrgb(static_cast<float>(linear));
        out[i++] = static_cast<uint8_t>(std::lround(std::clamp(encoded, 0.0, 1.0) * 255.0));
      }
    }
  }
  return out;
}

}  // namespace relit::synth
