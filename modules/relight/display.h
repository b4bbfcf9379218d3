// Turning linear renders into pictures people look at: a percentile exposure
// and the sRGB curve (the tone map every PNG of relight/evaluate/report uses),
// error heat maps and binary-mask erosion (OpenCV).
//
// Tone map: exposure e = 1 / P_p, P_p the p-th percentile of the Rec. 709
// luminance of the pixels inside a mask (all pixels without one); the PNG holds
// srgb(clamp(e * rgb, 0, 1)) with the IEC 61966-2-1 sRGB transfer curve. Two
// images meant to be compared side by side share one exposure.
#pragma once

#include <string>

#include "image/color.h"
#include "image/image.h"

namespace relight {

// Exposure mapping the `percentile` (0-100) of luminance over pixels with mask > 0.5 (every pixel when
// `mask` is null or empty) to 1; 1 when that luminance is not positive.
double PercentileExposure(const Image& linear_rgb, const Image* mask, double percentile);


// srgb(clamp(exposure * linear, 0, 1)) per RGB channel; a 3-channel image ready for an 8-bit PNG.
Image ToneMapSrgb(const Image& linear_rgb, double exposure);

// Heat map of a 1-channel image: value / max_value in [0, 1] through the perceptually uniform "inferno"
// colour map (OpenCV); pixels with mask <= 0.5 (when a mask is given) are mid grey. RGB in [0, 1].
Image HeatMap(const Image& value, double max_value, const Image* mask = nullptr);

// Binary mask (1 where channel 0 > 0.5) eroded by a (2r+1)^2 square (OpenCV); r = 0 only binarises.
Image ErodeMask(const Image& mask, int radius_px);

// Reads a mask file (PNG/EXR): 1 where channel 0 > 0.5 (of the file's range), else 0. Throws UserError naming it.
Image ReadMask(const std::string& path);

// Number of pixels with mask > 0.5.
size_t CountMask(const Image& mask);

// Writes an 8-bit PNG of a [0, 1] image atomically.
void WritePng(const std::string& path, const Image& image);
// Writes a float EXR atomically, uncompressed (rendered radiance barely compresses).
void WriteExr(const std::string& path, const Image& image);

}  // namespace relight
