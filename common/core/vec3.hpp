#pragma once
// Small 3-vector for the hot loops. Plain aggregate of three doubles so that an
// array of Vec3 is a contiguous array of doubles (x0 y0 z0 x1 ...), which keeps
// per-field arrays cache-friendly and lets the compiler vectorise the integrator.
#include <algorithm>
#include <cmath>

namespace mlcg {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;

  constexpr Vec3() = default;
  constexpr Vec3(double a, double b, double c) : x(a), y(b), z(c) {}

  constexpr Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  constexpr Vec3& operator-=(const Vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  constexpr Vec3& operator*=(double s) { x *= s; y *= s; z *= s; return *this; }
  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

constexpr Vec3 operator+(Vec3 a, const Vec3& b) { return a += b; }
constexpr Vec3 operator-(Vec3 a, const Vec3& b) { return a -= b; }
constexpr Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
constexpr Vec3 operator*(Vec3 a, double s) { return a *= s; }
constexpr Vec3 operator*(double s, Vec3 a) { return a *= s; }
constexpr Vec3 operator/(Vec3 a, double s) { return a *= (1.0 / s); }
constexpr bool operator==(const Vec3& a, const Vec3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

constexpr double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
constexpr double norm2(const Vec3& a) { return dot(a, a); }
inline double norm(const Vec3& a) { return std::sqrt(norm2(a)); }
inline Vec3 normalized(const Vec3& a) { return a / norm(a); }
inline bool finite(const Vec3& a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }
// The distance from p to the farthest corner of the box [lo, hi]: how far a body in the box reaches from p.
inline double farthest_corner(const Vec3& lo, const Vec3& hi, const Vec3& p) {
  const Vec3 d{std::max(p.x - lo.x, hi.x - p.x), std::max(p.y - lo.y, hi.y - p.y), std::max(p.z - lo.z, hi.z - p.z)};
  return norm(d);
}

// Three floats: storage for state that single precision represents well enough and that is large
// (the tangential overlap of every listed pair: half the bytes to stream each step). Arithmetic
// stays in Vec3: a Vec3f widens implicitly and is narrowed only where one is written.
struct Vec3f {
  float x = 0.0f, y = 0.0f, z = 0.0f;

  constexpr Vec3f() = default;
  constexpr explicit Vec3f(const Vec3& v)
      : x(static_cast<float>(v.x)), y(static_cast<float>(v.y)), z(static_cast<float>(v.z)) {}
  constexpr operator Vec3() const { return {x, y, z}; }
};

}  // namespace mlcg
