// Phone camera sensor model (relit-synth): fixed exposure, Poisson-Gaussian
// noise on linear values, sRGB encoding and 8-bit quantisation.
#pragma once

#include <cstdint>
#include <vector>

#include "core/image.h"

namespace relit::synth {

struct SensorParams {
  double exposure = 1.0;          // linear gain applied to scene radiance (fixed: no auto-exposure)
  double full_well_e = 800.0;     // electrons at linear value 1.0 (sets shot noise)
  double read_noise_e = 3.0;      // Gaussian read noise, electrons RMS
  void Check() const;
};

// Interleaved 8-bit RGB (row-major, width*height*3) of a linear radiance image:
// value = clamp(exposure * radiance) -> shot noise (Poisson, via its Gaussian
// approximation above 20 electrons) + read noise -> clamp -> sRGB -> round.
// Deterministic for (seed, stream).
std::vector<uint8_t> SensorCapture(const Image& radiance, const SensorParams& params,
                                   uint64_t seed, uint64_t stream);

}  // namespace relit::synth
