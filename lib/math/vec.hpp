#pragma once
// Small fixed-size vectors, 3x3 matrices and quaternions for per-element math that runs on
// both the host and CUDA devices. Scalar is float (CUDA backend) or double (CPU reference).
// Containers on the host use std::vector<Vec3<T>>; Eigen is used for sparse solves only.
#include <algorithm>
#include <cmath>

#include "math/hd.hpp"

namespace ebh {

template <class T>
struct Vec3 {
  T x{}, y{}, z{};
  EBH_HD constexpr Vec3() = default;
  EBH_HD constexpr Vec3(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
  EBH_HD T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  EBH_HD const T& operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  template <class U>
  EBH_HD explicit operator Vec3<U>() const { return {U(x), U(y), U(z)}; }
};

using Vec3d = Vec3<double>;
using Vec3f = Vec3<float>;

template <class T> EBH_HD Vec3<T> operator+(Vec3<T> a, Vec3<T> b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
template <class T> EBH_HD Vec3<T> operator-(Vec3<T> a, Vec3<T> b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
template <class T> EBH_HD Vec3<T> operator-(Vec3<T> a) { return {-a.x, -a.y, -a.z}; }
template <class T> EBH_HD Vec3<T> operator*(T s, Vec3<T> a) { return {s * a.x, s * a.y, s * a.z}; }
template <class T> EBH_HD Vec3<T> operator*(Vec3<T> a, T s) { return {s * a.x, s * a.y, s * a.z}; }
template <class T> EBH_HD Vec3<T> operator/(Vec3<T> a, T s) { return {a.x / s, a.y / s, a.z / s}; }
template <class T> EBH_HD Vec3<T>& operator+=(Vec3<T>& a, Vec3<T> b) { a.x += b.x; a.y += b.y; a.z += b.z; return a; }
template <class T> EBH_HD Vec3<T>& operator-=(Vec3<T>& a, Vec3<T> b) { a.x -= b.x; a.y -= b.y; a.z -= b.z; return a; }
template <class T> EBH_HD Vec3<T>& operator*=(Vec3<T>& a, T s) { a.x *= s; a.y *= s; a.z *= s; return a; }
template <class T> EBH_HD bool operator==(Vec3<T> a, Vec3<T> b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
template <class T> EBH_HD T dot(Vec3<T> a, Vec3<T> b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class T> EBH_HD Vec3<T> cross(Vec3<T> a, Vec3<T> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T> EBH_HD T squared_norm(Vec3<T> a) { return dot(a, a); }
template <class T> EBH_HD T norm(Vec3<T> a) { return EBH_SQRT(dot(a, a)); }
template <class T> EBH_HD Vec3<T> cwise_min(Vec3<T> a, Vec3<T> b) {
  return {a.x < b.x ? a.x : b.x, a.y < b.y ? a.y : b.y, a.z < b.z ? a.z : b.z};
}
template <class T> EBH_HD Vec3<T> cwise_max(Vec3<T> a, Vec3<T> b) {
  return {a.x > b.x ? a.x : b.x, a.y > b.y ? a.y : b.y, a.z > b.z ? a.z : b.z};
}
/// a / |a|, or zero for a zero vector.
/// a + t (b - a): from a (t = 0) to b (t = 1).
template <class T> EBH_HD Vec3<T> lerp(Vec3<T> a, Vec3<T> b, T t) { return a + t * (b - a); }
template <class T> EBH_HD Vec3<T> normalized(Vec3<T> a) {
  T n = norm(a);
  return n > T(0) ? a / n : Vec3<T>{};
}

/// Row-major 3x3 matrix: m[r][c].
template <class T>
struct Mat3 {
  T m[3][3]{};
  EBH_HD static Mat3 identity() { Mat3 r; r.m[0][0] = r.m[1][1] = r.m[2][2] = T(1); return r; }
  EBH_HD static Mat3 from_cols(Vec3<T> a, Vec3<T> b, Vec3<T> c) {
    Mat3 r;
    for (int i = 0; i < 3; ++i) { r.m[i][0] = a[i]; r.m[i][1] = b[i]; r.m[i][2] = c[i]; }
    return r;
  }
  EBH_HD Vec3<T> col(int c) const { return {m[0][c], m[1][c], m[2][c]}; }
  EBH_HD Vec3<T> row(int r) const { return {m[r][0], m[r][1], m[r][2]}; }
  EBH_HD T& operator()(int r, int c) { return m[r][c]; }
  EBH_HD const T& operator()(int r, int c) const { return m[r][c]; }
};
using Mat3d = Mat3<double>;
using Mat3f = Mat3<float>;

template <class T> EBH_HD Mat3<T> operator*(const Mat3<T>& a, const Mat3<T>& b) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return r;
}
template <class T> EBH_HD Vec3<T> operator*(const Mat3<T>& a, Vec3<T> v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z, a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}
template <class T> EBH_HD Mat3<T> operator+(const Mat3<T>& a, const Mat3<T>& b) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] + b.m[i][j];
  return r;
}
template <class T> EBH_HD Mat3<T> operator-(const Mat3<T>& a, const Mat3<T>& b) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] - b.m[i][j];
  return r;
}
template <class T> EBH_HD Mat3<T> operator*(T s, const Mat3<T>& a) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) r.m[i][j] = s * a.m[i][j];
  return r;
}
template <class T> EBH_HD Mat3<T> transpose(const Mat3<T>& a) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[j][i];
  return r;
}
template <class T> EBH_HD T determinant(const Mat3<T>& a) {
  return dot(a.col(0), cross(a.col(1), a.col(2)));
}
/// Cofactor matrix cof(A) = d det(A) / dA: the columns a1 x a2, a2 x a0, a0 x a1 (a_i the columns
/// of A), so that det(A) = a0 . (a1 x a2) and cof(A) = det(A) A^-T where A is invertible.
template <class T> EBH_HD Mat3<T> cofactor(const Mat3<T>& a) {
  return Mat3<T>::from_cols(cross(a.col(1), a.col(2)), cross(a.col(2), a.col(0)), cross(a.col(0), a.col(1)));
}
template <class T> EBH_HD T frobenius_sq(const Mat3<T>& a) {
  T s = 0;
  for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) s += a.m[i][j] * a.m[i][j];
  return s;
}
/// Inverse; the caller guarantees a non-singular matrix (rest shapes are validated at load).
template <class T> EBH_HD Mat3<T> inverse(const Mat3<T>& a) {
  Vec3<T> c0 = a.col(0), c1 = a.col(1), c2 = a.col(2);
  Vec3<T> r0 = cross(c1, c2), r1 = cross(c2, c0), r2 = cross(c0, c1);
  T inv_det = T(1) / dot(c0, r0);
  Mat3<T> r;
  for (int j = 0; j < 3; ++j) { r.m[0][j] = r0[j] * inv_det; r.m[1][j] = r1[j] * inv_det; r.m[2][j] = r2[j] * inv_det; }
  return r;
}
/// Skew-symmetric matrix [v]x with [v]x w = v x w (paper eq. A.7).
template <class T> EBH_HD Mat3<T> skew(Vec3<T> v) {
  Mat3<T> r;
  r.m[0][1] = -v.z; r.m[0][2] = v.y; r.m[1][0] = v.z; r.m[1][2] = -v.x; r.m[2][0] = -v.y; r.m[2][1] = v.x;
  return r;
}
template <class T> EBH_HD Mat3<T> outer(Vec3<T> a, Vec3<T> b) {
  Mat3<T> r;
  for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) r.m[i][j] = a[i] * b[j];
  return r;
}

/// Unit quaternion (w, x, y, z) — the storage order used in every file (docs/FORMATS.md).
template <class T>
struct Quat {
  T w{1}, x{}, y{}, z{};
  EBH_HD constexpr Quat() = default;
  EBH_HD constexpr Quat(T w_, T x_, T y_, T z_) : w(w_), x(x_), y(y_), z(z_) {}
  EBH_HD Vec3<T> vec() const { return {x, y, z}; }
};
using Quatd = Quat<double>;
using Quatf = Quat<float>;

/// Exactly the same components (a repeated sample), not the same rotation (q and -q differ).
template <class T> EBH_HD bool operator==(Quat<T> a, Quat<T> b) { return a.w == b.w && a.x == b.x && a.y == b.y && a.z == b.z; }

template <class T> EBH_HD Quat<T> operator*(Quat<T> a, Quat<T> b) {
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}
template <class T> EBH_HD Quat<T> conjugate(Quat<T> q) { return {q.w, -q.x, -q.y, -q.z}; }
template <class T> EBH_HD Quat<T> normalized(Quat<T> q) {
  T n = EBH_SQRT(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}
template <class T> EBH_HD Vec3<T> rotate(Quat<T> q, Vec3<T> v) {
  Vec3<T> u = q.vec();
  Vec3<T> t = T(2) * cross(u, v);
  return v + q.w * t + cross(u, t);
}
template <class T> EBH_HD Mat3<T> to_matrix(Quat<T> q) {
  return Mat3<T>::from_cols(rotate(q, Vec3<T>{1, 0, 0}), rotate(q, Vec3<T>{0, 1, 0}), rotate(q, Vec3<T>{0, 0, 1}));
}
/// Quaternion of the rotation by the rotation vector w (axis * angle), exact for all angles.
template <class T> EBH_HD Quat<T> quat_from_rotvec(Vec3<T> w) {
  T a = norm(w);
  if (a < T(1e-8)) return normalized(Quat<T>{T(1), w.x / 2, w.y / 2, w.z / 2});
  T s = sin(a / 2) / a;
  return {cos(a / 2), s * w.x, s * w.y, s * w.z};
}
/// Rotation vector (axis * angle, angle in [0, pi]) of a unit quaternion.
template <class T> EBH_HD Vec3<T> rotvec_from_quat(Quat<T> q) {
  if (q.w < 0) q = Quat<T>{-q.w, -q.x, -q.y, -q.z};
  Vec3<T> v = q.vec();
  T s = norm(v);
  if (s < T(1e-8)) return T(2) * v;
  T angle = T(2) * atan2(s, q.w);
  return (angle / s) * v;
}
/// Spherical linear interpolation on the shortest arc, s in [0, 1] (host: the recordings' and the
/// tf links' orientations between samples).
inline Quatd slerp(Quatd a, Quatd b, double s) {
  double d = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
  if (d < 0) { b = Quatd{-b.w, -b.x, -b.y, -b.z}; d = -d; }
  double wa, wb;
  if (d > 0.9995) {  // nearly parallel: sin(theta) ~ 0, nlerp is exact to O(theta^3)
    wa = 1 - s;
    wb = s;
  } else {
    double theta = std::acos(std::min(d, 1.0));
    double st = std::sin(theta);
    wa = std::sin((1 - s) * theta) / st;
    wb = std::sin(s * theta) / st;
  }
  return normalized(Quatd{wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y, wa * a.z + wb * b.z});
}

}  // namespace ebh
