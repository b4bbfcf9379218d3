// The one tangent-frame convention of the project.
//
// A surface point's local frame has its normal as +z. The tangent (+x) and
// bitangent (+y) are a continuous function of the normal alone (Frisvad 2012,
// "Building an orthonormal basis from a 3D unit vector without normalization"),
// singular only at n = (0, 0, -1), where the frame is fixed explicitly. Every
// per-vertex quantity on the hemisphere -- visibility maps, BRDF slices, local
// view directions, rotated lighting -- is expressed in this frame, so
// visibility baking, observation extraction, wavelet rotation and rendering
// agree. Templated on the scalar type (double, float, ceres::Jet).
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace relight {

template <typename T>
struct LocalFrame {
  Eigen::Matrix<T, 3, 1> tangent;    // local +x, in world coordinates
  Eigen::Matrix<T, 3, 1> bitangent;  // local +y
  Eigen::Matrix<T, 3, 1> normal;     // local +z

  // World direction -> local coordinates.
  Eigen::Matrix<T, 3, 1> ToLocal(const Eigen::Matrix<T, 3, 1>& dir_world) const {
    return {tangent.dot(dir_world), bitangent.dot(dir_world), normal.dot(dir_world)};
  }
  // Local coordinates -> world direction.
  Eigen::Matrix<T, 3, 1> ToWorld(const Eigen::Matrix<T, 3, 1>& dir_local) const {
    return tangent * dir_local.x() + bitangent * dir_local.y() + normal * dir_local.z();
  }
  // Rows are tangent, bitangent, normal: local_from_world.
  Eigen::Matrix<T, 3, 3> LocalFromWorld() const {
    Eigen::Matrix<T, 3, 3> m;
    m.row(0) = tangent.transpose();
    m.row(1) = bitangent.transpose();
    m.row(2) = normal.transpose();
    return m;
  }
};

// The frame of a unit normal (not re-normalised here).
template <typename T>
LocalFrame<T> FrameFromNormal(const Eigen::Matrix<T, 3, 1>& n) {
  LocalFrame<T> f;
  f.normal = n;
  if (n.z() < T(-0.9999999)) {
    f.tangent = Eigen::Matrix<T, 3, 1>(T(0), T(-1), T(0));
    f.bitangent = Eigen::Matrix<T, 3, 1>(T(-1), T(0), T(0));
    return f;
  }
  const T a = T(1) / (T(1) + n.z());
  const T b = -n.x() * n.y() * a;
  f.tangent = Eigen::Matrix<T, 3, 1>(T(1) - n.x() * n.x() * a, b, -n.x());
  f.bitangent = Eigen::Matrix<T, 3, 1>(b, T(1) - n.y() * n.y() * a, -n.y());
  return f;
}

}  // namespace relight
