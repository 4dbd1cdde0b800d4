#pragma once
// Analytic walls. Each answers one question for a sphere centre x: the closest
// wall point, the unit normal from it to x and the distance (WallGeom).
//
// PlaneWall is a half-space boundary: particles live on the side the normal
// points to; a centre behind the plane still gets pushed out (dist < 0).
// RevolutionWall is any surface made by turning a segment about an axis: a
// cylinder (constant radius), a cone frustum (two radii) or a disk / annulus
// (constant axial position). The closest point of a surface of revolution
// lies in the meridian half-plane of x, so the 3-D problem is a 2-D
// point-to-segment one. Contacts beyond the segment's ends (the rim circles)
// exist only where the case asks for them.
#include <cmath>

#include "core/vec3.hpp"

namespace mlcg {

struct WallGeom {
  Vec3 point;   // closest point on the wall
  Vec3 n;       // unit normal from the wall point to the sphere centre
  double dist;  // signed distance along n (negative only behind a plane)
};

struct PlaneWall {
  Vec3 p, n;  // n unit

  inline bool closest(const Vec3& x, WallGeom& g) const {
    const double d = dot(x - p, n);
    g.point = x - d * n;
    g.n = n;
    g.dist = d;
    return true;
  }
};

struct RevolutionWall {
  Vec3 c, a;           // axis point and unit axis
  double rho0, s0;     // segment end A in (radius, axial) coordinates
  double rho1, s1;     // segment end B
  bool rim0 = false;   // contacts with the circle at A
  bool rim1 = false;   // contacts with the circle at B

  inline bool closest(const Vec3& x, WallGeom& g) const {
    const Vec3 rel = x - c;
    const double s = dot(rel, a);
    const Vec3 radial = rel - s * a;
    const double rho = std::sqrt(norm2(radial));
    Vec3 e;
    if (rho > 0.0) {
      e = radial * (1.0 / rho);
    } else {  // on the axis: every azimuth is equally close; pick one
      e = std::fabs(a.x) < 0.9 ? normalized(cross(a, Vec3{1, 0, 0})) : normalized(cross(a, Vec3{0, 1, 0}));
    }
    const double dr = rho1 - rho0, ds = s1 - s0;
    const double len2 = dr * dr + ds * ds;
    double t = len2 > 0.0 ? ((rho - rho0) * dr + (s - s0) * ds) / len2 : 0.0;
    if (t < 0.0) {
      if (!rim0) return false;
      t = 0.0;
    } else if (t > 1.0) {
      if (!rim1) return false;
      t = 1.0;
    }
    const double qr = rho0 + t * dr, qs = s0 + t * ds;
    g.point = c + qs * a + qr * e;
    const Vec3 d = x - g.point;
    g.dist = std::sqrt(norm2(d));
    if (g.dist > 0.0) {
      g.n = d * (1.0 / g.dist);
    } else {  // centre on the surface: use the meridian normal
      const double inv = 1.0 / std::sqrt(len2);
      g.n = (ds * inv) * e - (dr * inv) * a;
    }
    return true;
  }
};

}  // namespace mlcg
