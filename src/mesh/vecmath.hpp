#pragma once
// Small vector helpers on the Mesh's std::array types (private to the module).
#include <array>
#include <cmath>

#include <mucosa/mesh/mesh.hpp>

namespace mucosa::mesh::detail {

using Vec3d = std::array<double, 3>;

template <class T>
inline std::array<T, 3> operator+(const std::array<T, 3>& a, const std::array<T, 3>& b) noexcept {
    return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
template <class T>
inline std::array<T, 3> operator-(const std::array<T, 3>& a, const std::array<T, 3>& b) noexcept {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
template <class T>
inline std::array<T, 3> operator*(const std::array<T, 3>& a, T s) noexcept {
    return {a[0] * s, a[1] * s, a[2] * s};
}
template <class T>
inline std::array<T, 3> operator*(T s, const std::array<T, 3>& a) noexcept {
    return {a[0] * s, a[1] * s, a[2] * s};
}
template <class T>
inline std::array<T, 3>& operator+=(std::array<T, 3>& a, const std::array<T, 3>& b) noexcept {
    a[0] += b[0];
    a[1] += b[1];
    a[2] += b[2];
    return a;
}
template <class T>
inline T dot(const std::array<T, 3>& a, const std::array<T, 3>& b) noexcept {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class T>
inline std::array<T, 3> cross(const std::array<T, 3>& a, const std::array<T, 3>& b) noexcept {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class T>
inline T length(const std::array<T, 3>& a) noexcept {
    return std::sqrt(dot(a, a));
}
// a / |a|, or `fallback` when |a| is zero or not finite.
template <class T>
inline std::array<T, 3> normalizeOr(const std::array<T, 3>& a, const std::array<T, 3>& fallback) noexcept {
    const T l = length(a);
    if (!(l > T(1e-30)) || !std::isfinite(l)) return fallback;
    return a * (T(1) / l);
}

inline Vec3d toD(const Vec3& a) noexcept {
    return {a[0], a[1], a[2]};
}
inline Vec3 toF(const Vec3d& a) noexcept {
    return {static_cast<float>(a[0]), static_cast<float>(a[1]), static_cast<float>(a[2])};
}

inline bool finite(const Vec3& a) noexcept {
    return std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]);
}

// A unit vector orthogonal to unit n (Duff et al. 2017, "Building an
// orthonormal basis, revisited", JCGT 6(1), listing 3).
template <class T>
inline std::array<T, 3> anyPerpendicular(const std::array<T, 3>& n) noexcept {
    const T sign = std::copysign(T(1), n[2]);
    const T a = T(-1) / (sign + n[2]);
    const T b = n[0] * n[1] * a;
    return {T(1) + sign * n[0] * n[0] * a, sign * b, -sign * n[0]};
}

// Interior angle at p0 of the triangle (p0, p1, p2), robust for thin triangles.
template <class T>
inline T cornerAngle(const std::array<T, 3>& p0, const std::array<T, 3>& p1, const std::array<T, 3>& p2) noexcept {
    const std::array<T, 3> e1 = p1 - p0, e2 = p2 - p0;
    return std::atan2(length(cross(e1, e2)), dot(e1, e2));
}

}  // namespace mucosa::mesh::detail
