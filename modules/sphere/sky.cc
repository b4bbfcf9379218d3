#include "sphere/sky.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"

namespace relight {
namespace {

struct Perez {
  double a, b, c, d, e;
  // Perez et al. 1993 sky distribution F(theta, gamma).
  double operator()(double cos_theta, double gamma) const {
    const double cos_gamma = std::cos(gamma);
    return (1.0 + a * std::exp(b / std::max(cos_theta, 1e-3))) *
           (1.0 + c * std::exp(d * gamma) + e * cos_gamma * cos_gamma);
  }
};

// Preetham 1999, Appendix A.2: distribution coefficients as linear functions of turbidity.
Perez LuminanceCoefficients(double t) {
  return {0.1787 * t - 1.4630, -0.3554 * t + 0.4275, -0.0227 * t + 5.3251, 0.1206 * t - 2.5771, -0.0670 * t + 0.3703};
}
Perez XCoefficients(double t) {
  return {-0.0193 * t - 0.2592, -0.0665 * t + 0.0008, -0.0004 * t + 0.2125, -0.0641 * t - 0.8989, -0.0033 * t + 0.0452};
}
Perez YCoefficients(double t) {
  return {-0.0167 * t - 0.2608, -0.0950 * t + 0.0092, -0.0079 * t + 0.2102, -0.0441 * t - 1.6537, -0.0109 * t + 0.0529};
}

Eigen::Vector3d XyYToLinearSrgb(double x, double y, double lum) {
  const double X = x * lum / y, Y = lum, Z = (1.0 - x - y) * lum / y;
  return {std::max(0.0, 3.2406 * X - 1.5372 * Y - 0.4986 * Z), std::max(0.0, -0.9689 * X + 1.8758 * Y + 0.0415 * Z),
          std::max(0.0, 0.0557 * X - 0.2040 * Y + 1.0570 * Z)};
}

struct SkyState {
  Eigen::Vector3d sun;
  double theta_s;
  Perez fy, fx, fyy;
  double zenith_Y, zenith_x, zenith_y;
  double norm_Y, norm_x, norm_y;
};

SkyState MakeSkyState(const SunSkyParams& p) {
  SkyState s;
  s.sun = p.sun_dir_world.normalized();
  s.theta_s = std::acos(std::clamp(s.sun.z(), 0.0, 1.0));
  const double t = p.turbidity, th = s.theta_s;
  s.fy = LuminanceCoefficients(t);
  s.fx = XCoefficients(t);
  s.fyy = YCoefficients(t);
  const double chi = (4.0 / 9.0 - t / 120.0) * (M_PI - 2.0 * th);
  s.zenith_Y = std::max(0.0, (4.0453 * t - 4.9710) * std::tan(chi) - 0.2155 * t + 2.4192);
  const double th2 = th * th, th3 = th2 * th;
  s.zenith_x = t * t * (0.00166 * th3 - 0.00375 * th2 + 0.00209 * th) +
               t * (-0.02903 * th3 + 0.06377 * th2 - 0.03202 * th + 0.00394) +
               (0.11693 * th3 - 0.21196 * th2 + 0.06052 * th + 0.25886);
  s.zenith_y = t * t * (0.00275 * th3 - 0.00610 * th2 + 0.00317 * th) +
               t * (-0.04214 * th3 + 0.08970 * th2 - 0.04153 * th + 0.00516) +
               (0.15346 * th3 - 0.26756 * th2 + 0.06670 * th + 0.26688);
  s.norm_Y = s.fy(1.0, th);
  s.norm_x = s.fx(1.0, th);
  s.norm_y = s.fyy(1.0, th);
  return s;
}

Eigen::Vector3d SkyRadiance(const SkyState& s, const Eigen::Vector3d& d) {
  const double cos_theta = std::max(d.z(), 0.0);
  const double gamma = std::acos(std::clamp(d.dot(s.sun), -1.0, 1.0));
  const double Y = s.zenith_Y * s.fy(cos_theta, gamma) / s.norm_Y;
  const double x = s.zenith_x * s.fx(cos_theta, gamma) / s.norm_x;
  const double y = s.zenith_y * s.fyy(cos_theta, gamma) / s.norm_y;
  return XyYToLinearSrgb(x, y, Y);
}

}  // namespace

void SunSkyParams::Check() const {
  if (!(sun_dir_world.norm() > 0)) RELIGHT_USER_ERROR() << "sun direction must be non-zero";
  if (sun_dir_world.normalized().z() < -1e-9)
    RELIGHT_USER_ERROR() << "sun direction " << sun_dir_world.transpose()
                         << " is below the horizon: the Preetham sky model needs z >= 0";
  if (!(turbidity >= 1.7 && turbidity <= 10))
    RELIGHT_USER_ERROR() << "turbidity " << turbidity << " is outside the Preetham model's range [1.7, 10]";
  if (!(ground_albedo >= 0 && ground_albedo <= 1))
    RELIGHT_USER_ERROR() << "ground albedo " << ground_albedo << " must lie in [0, 1]";
  if (!(sun_radius_deg > 0 && sun_radius_deg < 20))
    RELIGHT_USER_ERROR() << "sun radius " << sun_radius_deg << " deg must lie in (0, 20)";
  if (!(intensity >= 0)) RELIGHT_USER_ERROR() << "intensity " << intensity << " must be >= 0";
}

Eigen::Vector3d PreethamSkyRadiance(const SunSkyParams& params, const Eigen::Vector3d& dir_world) {
  return params.intensity * SkyRadiance(MakeSkyState(params), dir_world.normalized());
}

Eigen::Vector3d SunIlluminance(const SunSkyParams& params) {
  const Eigen::Vector3d sun = params.sun_dir_world.normalized();
  const double zenith_deg = std::acos(std::clamp(sun.z(), 0.0, 1.0)) * 180.0 / M_PI;
  // Kasten & Young 1989 relative optical air mass.
  const double air_mass =
      1.0 / (std::cos(zenith_deg * M_PI / 180.0) + 0.50572 * std::pow(96.07995 - zenith_deg, -1.6364));
  const double beta = 0.04608365822050 * params.turbidity - 0.04586025928522;  // Angstrom turbidity (Preetham A.3)
  const double lambda_um[3] = {0.610, 0.550, 0.465};
  Eigen::Vector3d rgb;
  for (int c = 0; c < 3; ++c) {
    const double tau_rayleigh = 0.008735 * std::pow(lambda_um[c], -4.08);
    const double tau_aerosol = beta * std::pow(lambda_um[c], -1.3);
    rgb[c] = std::exp(-air_mass * (tau_rayleigh + tau_aerosol));
  }
  // Luminous solar constant 128 klx; linear sRGB (1,1,1) has luminance 1.
  return params.intensity * 128.0 * rgb;
}

EnvMap MakeSunSky(const SunSkyParams& params, int latlong_height) {
  params.Check();
  RELIGHT_CHECK_GT(latlong_height, 1);
  const int h = latlong_height, w = 2 * h;
  const SkyState sky = MakeSkyState(params);
  const Eigen::Vector3d sun = sky.sun;
  const double radius = params.sun_radius_deg * M_PI / 180.0;
  const double cos_radius = std::cos(radius);
  const Eigen::Vector3d sun_e = SunIlluminance(params);  // klx at normal incidence
  Image image(w, h, 3);
  auto dir = [&](double u, double v) {
    const double theta = M_PI * v, phi = 2 * M_PI * u;
    return Eigen::Vector3d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  };
  auto pixel_solid_angle = [&](int y) {
    return 2 * M_PI / w * (std::cos(M_PI * y / h) - std::cos(M_PI * (y + 1) / h));
  };
  // Sky (upper half), supersampled 4x4 per pixel; rows below the horizon are filled later.
  std::vector<double> coverage(size_t(w) * h, 0.0);
  const double pixel_diag = std::sqrt(2.0) * M_PI / h;
  tbb::parallel_for(0, h, [&](int y) {
    const int ss = 4;
    for (int x = 0; x < w; ++x) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double wsum = 0;
      for (int sy = 0; sy < ss; ++sy) {
        const double v = (y + (sy + 0.5) / ss) / h;
        const double weight = std::sin(M_PI * v);
        for (int sx = 0; sx < ss; ++sx) {
          const Eigen::Vector3d d = dir((x + (sx + 0.5) / ss) / w, v);
          if (d.z() > 0) sum += weight * SkyRadiance(sky, d);
          wsum += weight;
        }
      }
      const Eigen::Vector3d avg = params.intensity * sum / wsum;
      for (int c = 0; c < 3; ++c) image.at(x, y, c) = float(avg[c]);
      // Sun coverage: supersample finely only near the disk.
      const Eigen::Vector3d centre = dir((x + 0.5) / w, (y + 0.5) / h);
      const double angle = std::acos(std::clamp(centre.dot(sun), -1.0, 1.0));
      // A pixel near the pole spans a wide azimuth range; test the pixel's angular extent generously.
      const double extent =
          std::max(pixel_diag, 2 * M_PI / w * std::max(std::sin(M_PI * y / h), std::sin(M_PI * (y + 1) / h)));
      if (angle < radius + extent) {
        const int fine = 32;
        double cov = 0, cov_w = 0;
        for (int sy = 0; sy < fine; ++sy) {
          const double v = (y + (sy + 0.5) / fine) / h;
          const double weight = std::sin(M_PI * v);
          for (int sx = 0; sx < fine; ++sx) {
            if (dir((x + (sx + 0.5) / fine) / w, v).dot(sun) >= cos_radius) cov += weight;
            cov_w += weight;
          }
        }
        coverage[size_t(y) * w + x] = cov / cov_w;
      }
    }
  });
  // Sun disk: radiance such that the rasterised disk integrates to the sun's illuminance.
  double covered_solid_angle = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) covered_solid_angle += coverage[size_t(y) * w + x] * pixel_solid_angle(y);
  if (covered_solid_angle <= 0) {  // disk far smaller than a pixel and missed: put it in the nearest pixel
    double phi = std::atan2(sun.y(), sun.x());
    if (phi < 0) phi += 2 * M_PI;
    const int x = std::clamp(int(phi / (2 * M_PI) * w), 0, w - 1);
    const int y = std::clamp(int(std::acos(std::clamp(sun.z(), -1.0, 1.0)) / M_PI * h), 0, h - 1);
    coverage[size_t(y) * w + x] = 1.0;
    covered_solid_angle = pixel_solid_angle(y);
  }
  const Eigen::Vector3d sun_radiance = sun_e / covered_solid_angle;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double cov = coverage[size_t(y) * w + x];
      if (cov > 0)
        for (int c = 0; c < 3; ++c) image.at(x, y, c) += float(cov * sun_radiance[c]);
    }
  // Ground: Lambertian plane lit by the sun and the sky (horizontal irradiance).
  Eigen::Vector3d e_horizontal = sun_e * std::max(sun.z(), 0.0);
  for (int y = 0; y < h; ++y) {
    const double theta_mid = M_PI * (y + 0.5) / h;
    if (theta_mid >= M_PI / 2) break;
    for (int x = 0; x < w; ++x) {
      const double cov = coverage[size_t(y) * w + x];
      Eigen::Vector3d sky_only(image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2));
      sky_only -= cov * sun_radiance;
      e_horizontal += sky_only * std::cos(theta_mid) * pixel_solid_angle(y);
    }
  }
  const Eigen::Vector3d ground = params.ground_albedo * e_horizontal / M_PI;
  for (int y = 0; y < h; ++y) {
    // Fraction of the row below the horizon (theta > pi/2), by solid angle.
    const double c0 = std::cos(M_PI * y / h), c1 = std::cos(M_PI * (y + 1) / h);
    const double below = std::clamp((std::min(c0, 0.0) - std::min(c1, 0.0)) / (c0 - c1), 0.0, 1.0);
    if (below <= 0) continue;
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) image.at(x, y, c) += float(below * ground[c]);
  }
  return EnvMap::FromLatLong(std::move(image));
}

}  // namespace relight
