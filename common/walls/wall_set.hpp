#pragma once
// All walls of a level and, per particle, the wall primitives it may touch
// before the next neighbour-list rebuild (candidates within r + skin). A
// primitive is an analytic wall or one triangle of a mesh; primitive ids are
// dense: analytic walls first, then each mesh's triangles. The force kernel
// (forces/wall_kernel.hpp) walks a particle's candidates only.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/particles.hpp"
#include "walls/analytic.hpp"
#include "walls/triangle_mesh.hpp"

namespace mlcg {

struct AnalyticWall {
  enum class Kind : uint8_t { Plane, Revolution } kind;
  PlaneWall plane;
  RevolutionWall rev;

  inline bool closest(const Vec3& x, WallGeom& g) const {
    return kind == Kind::Plane ? plane.closest(x, g) : rev.closest(x, g);
  }
};

class WallSet {
 public:
  struct Info {
    std::string name;
    int material = 0;
    bool active = true;
    bool is_mesh = false;
    int32_t prim_begin = 0, prim_end = 0;  // primitive id range
    int mesh = -1;                         // index into meshes() when is_mesh
    // The surface's motion: a velocity along it, or a turn about an axis (velocity_at). For a mesh that
    // moves rigidly these follow its motion (set_time); otherwise the geometry stays in place.
    bool moving = false;
    Vec3 surface_velocity;
    Vec3 spin;         // angular velocity [rad/s] about the axis through spin_center
    Vec3 spin_center;
    // A mesh moved rigidly: world = R body + shift, body being the mesh as read.
    bool rigid = false;
    Vec3 rot[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // the rows of R
    Vec3 shift;
    Vec3 move_velocity, move_spin, move_center;  // of the motion from t = 0
    double reach = 0.0;                          // the farthest point of the mesh from move_center
    Vec3 to_body(const Vec3& x) const {
      if (!rigid) return x;
      const Vec3 d = x - shift;
      return rot[0] * d.x + rot[1] * d.y + rot[2] * d.z;  // R^T d
    }
    Vec3 turn(const Vec3& b) const { return {dot(rot[0], b), dot(rot[1], b), dot(rot[2], b)}; }  // R b
    Vec3 to_world(const Vec3& b) const { return turn(b) + shift; }
  };

  int add_analytic(const std::string& name, int material, const AnalyticWall& w);
  int add_mesh(const std::string& name, int material, std::shared_ptr<const TriangleMesh> mesh);

  size_t walls() const { return info_.size(); }
  const Info& info(size_t w) const { return info_[w]; }
  int find(const std::string& name) const;  // -1 if absent
  void set_active(size_t w, bool on) { info_[w].active = on; }
  // Wall w's surface slides at velocity u and turns at spin (rad/s, a vector along the axis) about the axis
  // through center; all zero: at rest.
  void set_motion(size_t w, const Vec3& u, const Vec3& spin, const Vec3& center);
  // Mesh w moves rigidly from t = 0: at velocity u, turning at spin (rad/s, along the axis) about the axis
  // through center, which moves along at u.
  void set_rigid_motion(size_t w, const Vec3& u, const Vec3& spin, const Vec3& center);
  // Places the rigidly moving meshes where they are at time t (cheap: each is one pose).
  void set_time(double t);
  bool has_rigid() const { return rigid_; }
  // An upper bound on how far a point of a rigidly moving mesh has moved since the candidates were built.
  double moved_since_build() const;
  // The velocity of wall w's surface at a point on it (zero for a wall at rest).
  Vec3 velocity_at(size_t w, const Vec3& point) const {
    const Info& in = info_[w];
    return in.surface_velocity + cross(in.spin, point - in.spin_center);
  }
  bool active(size_t w) const { return info_[w].active; }

  int32_t analytic_count() const { return static_cast<int32_t>(analytic_.size()); }
  const AnalyticWall& analytic(int32_t prim) const { return analytic_[static_cast<size_t>(prim)]; }
  int wall_of_prim(int32_t prim) const;
  const TriangleMesh& mesh(int m) const { return *meshes_[static_cast<size_t>(m)]; }

  // Per-particle candidate primitives, grouped by wall (a mesh's triangles are contiguous).
  std::vector<int32_t> first{0};
  std::vector<int32_t> prim;
  std::vector<Vec3> hist;
  // The particles that have candidates, ascending: the kernel walks these only (a tenth of a silo's
  // particles, scattered among the others).
  std::vector<int32_t> near;

  // True if the segment a-b crosses an active wall (used by insertion: a particle
  // poured from above can only reach places its vertical line from the ceiling
  // reaches without crossing a wall).
  bool crosses(const Vec3& a, const Vec3& b) const;
  // True if the sphere (x, r) overlaps an active wall (behind a plane counts as overlapping).
  bool touches(const Vec3& x, double r) const;
  // Largest overlap r - distance of the sphere (x, r) with an active wall, 0 when it touches none
  // (a centre behind a plane overlaps by r plus its depth).
  double overlap(const Vec3& x, double r) const;

  void build_candidates(const Particles& p, double skin, bool with_history);
  // The candidates of particles [first_new, n_local) appended since the last build, the others' kept
  // (their history too; the new ones start with none).
  void append_candidates(const Particles& p, size_t first_new, double skin, bool with_history);
  void save_history(const Particles& p, ContactHistory& out) const;
  void load_history(const ContactHistory& in);
  static int64_t history_key(int32_t prim) { return -1 - static_cast<int64_t>(prim); }

 private:
  std::vector<Info> info_;
  std::vector<AnalyticWall> analytic_;
  std::vector<int> analytic_wall_;  // wall index of each analytic primitive
  std::vector<std::shared_ptr<const TriangleMesh>> meshes_;
  int32_t next_prim_ = 0;
  std::vector<int32_t> scratch_;
  bool rigid_ = false;
  double time_ = 0.0, build_time_ = 0.0;
};

}  // namespace mlcg
