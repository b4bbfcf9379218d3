// A procedural sun-and-sky environment that needs no file.
//
// Sky: Preetham, Shirley, Smits, "A Practical Analytic Model for Daylight"
// (SIGGRAPH 1999): Perez luminance and chromaticity distributions (their eq. 3
// and Appendix A.2 coefficient tables) with the zenith luminance and
// chromaticity fits of their Appendix A.2, converted xyY -> XYZ -> linear sRGB.
// Sun: a disk of configurable angular radius whose illuminance at normal
// incidence is the luminous solar constant (128 klx) attenuated along the air
// mass (Kasten & Young 1989) by Rayleigh scattering (Leckner's 0.008735
// lambda^-4.08) and aerosols (Angstrom, beta from turbidity, alpha = 1.3), as
// in Preetham's Appendix A.3, evaluated at three effective wavelengths
// (R 610, G 550, B 465 nm). The disk radiance is that illuminance divided by
// the disk's solid angle, so a larger disk (for low-resolution maps) keeps the
// sun's irradiance. Ground: the lower hemisphere is a Lambertian plane of
// the given albedo lit by sun and sky, radiance albedo * E_horizontal / pi.
// Units: kcd/m^2 (Preetham's luminance unit) times `intensity`.
// Written by hand: no Debian library provides the Preetham model.
#pragma once

#include <Eigen/Core>

#include "sphere/envmap.h"

namespace relight {

// Parameters of MakeSunSky.
struct SunSkyParams {
  Eigen::Vector3d sun_dir_world = Eigen::Vector3d(0.5, 0.0, 0.8660254);  // towards the sun; must have z >= 0
  double turbidity = 3;         // Preetham turbidity, 1.7 (very clear) .. 10 (hazy)
  double ground_albedo = 0.2;   // Lambertian albedo of the lower hemisphere, 0 .. 1
  double sun_radius_deg = 0.5;  // angular radius of the sun disk (the real sun: 0.27); > 0, < 20
  double intensity = 1.0;       // overall scale; 1 gives kcd/m^2

  // Throws UserError naming the violated constraint.
  void Check() const;
};

// Lat-long EnvMap (width 2 h) of the sun, sky and ground. The sun disk is
// rasterised by coverage (supersampled) and renormalised so its integral is
// exactly its illuminance, whatever the resolution.
EnvMap MakeSunSky(const SunSkyParams& params, int latlong_height);

// Sky radiance (no sun disk, no ground) in a world direction with z > 0, linear sRGB, kcd/m^2.
Eigen::Vector3d PreethamSkyRadiance(const SunSkyParams& params, const Eigen::Vector3d& dir_world);
// Sun illuminance at normal incidence [klx], linear sRGB (luminance-weighted channels).
Eigen::Vector3d SunIlluminance(const SunSkyParams& params);

}  // namespace relight
