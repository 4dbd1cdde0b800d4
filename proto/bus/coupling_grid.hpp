#pragma once
// The geometry of one coupling region, as both sides of the bus see it: cubic
// cells on a box, of which the active ones (clipped to the geometry) take
// part. Layer k = nz - 1 is the transition layer; each of its active cells has
// one boundary face, its top face; the active cells below are correction
// cells. Where the geometry goes on beside the box (a region that does not
// span the vessel) the box's sides are boundary faces too (side_faces): mass
// crosses them both ways like the top; so does an open bottom (bottom_faces).
// Faces are numbered: the top faces in the order of the transition cells, then
// the side faces, then the bottom faces; per-cell arrays
// follow `cells` (ascending flat index i + nx (j + ny k)).
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/vec3.hpp"
#include "mlcg/bus.pb.h"

namespace mlcg::bus {

// Which face of a cell a boundary face is; the inward normal of each is -z, +x, -x, +y, -y, +z.
enum class Side : uint8_t { Top = 0, XLo = 1, XHi = 2, YLo = 3, YHi = 4, Bottom = 5 };

class CouplingGeometry {
 public:
  CouplingGeometry() = default;
  // Throws std::invalid_argument on an inconsistent grid (sizes, unsorted or out-of-range cells).
  explicit CouplingGeometry(const CouplingGrid& g);

  const CouplingGrid& grid() const { return g_; }
  double cell_size() const { return g_.cell_size(); }
  size_t cells() const { return cells_.size(); }
  size_t faces() const { return faces_.size(); }
  size_t top_faces() const { return top_faces_; }  // faces [0, top_faces()) are top faces
  Side side_of_face(size_t f) const { return side_[f]; }
  bool is_top(size_t f) const { return f < top_faces_; }
  static Vec3 inward(Side s);  // unit normal into the region of a face on side s
  Vec3 face_inward(size_t f) const { return inward(side_[f]); }
  int normal_axis(size_t f) const { return axis_of(side_[f]); }  // 0, 1, 2: x, y, z
  static int axis_of(Side s) { return s == Side::Top || s == Side::Bottom ? 2 : s <= Side::XHi ? 0 : 1; }
  // The box of points within `depth` inside face f (the face's square times depth along its normal).
  void face_slab(size_t f, double depth, Vec3& lo, Vec3& hi) const { cell_slab(faces_[f], side_[f], depth, lo, hi); }
  // The same for side s of active cell c, a boundary face or not.
  void cell_slab(size_t c, Side s, double depth, Vec3& lo, Vec3& hi) const;
  // Boundary face on side s of active cell c, or -1.
  int side_face(size_t c, Side s) const;
  // The box sides that have boundary faces (the open bottom among them), in the order of their first face.
  const std::vector<Side>& open_sides() const { return open_sides_; }
  // How far x lies inside the box's side s (negative: beyond it); for Side::Top, below the top.
  double depth_inside(Side s, const Vec3& x) const;
  uint32_t flat(size_t c) const { return cells_[c]; }
  bool is_transition(size_t c) const { return face_of_cell_[c] >= 0; }
  int face_of_cell(size_t c) const { return face_of_cell_[c]; }
  size_t cell_of_face(size_t f) const { return faces_[f]; }

  Vec3 origin() const { return {g_.ox(), g_.oy(), g_.oz()}; }
  Vec3 cell_lo(size_t c) const;
  Vec3 cell_centre(size_t c) const;
  double top() const { return g_.oz() + g_.nz() * g_.cell_size(); }  // height of the boundary surface
  Vec3 box_lo() const { return origin(); }
  Vec3 box_hi() const { return hi_; }

  // Fraction of active cell c's volume / boundary face f's area inside the walls (1 when the grid
  // does not say): the statistics divide by the inside volume, the traction acts on the inside area.
  double inside_volume(size_t c) const { return g_.cell_inside_size() ? g_.cell_inside(static_cast<int>(c)) : 1.0; }
  double inside_area(size_t f) const { return g_.face_inside_size() ? g_.face_inside(static_cast<int>(f)) : 1.0; }

  // Active cell containing x, or -1 (outside the box or in an inactive cell).
  int locate(const Vec3& x) const;
  // Boundary face whose column (x, y within the face) contains x, or -1.
  // Out of line on purpose: inlined into its callers the compiler contracts their arithmetic differently, and the
  // results move in the sixth digit.
  int face_column(const Vec3& x) const;
  // The boundary face through which a point outside the region most likely left it: the face whose
  // column holds it, else the face nearest to it; -1 when the grid has no face.
  int exit_face(const Vec3& x) const;
  // Whether a point outside the region lies beside it (further beyond a side than above the top) where that
  // side is no boundary face: the box's side there lies outside the vessel, so a particle got there by
  // leaving the vessel (a stream off a belt's end, out of a side-wall hole), not by crossing into the coarse
  // level's part of it.
  bool beside_a_closed_side(const Vec3& x) const;
  // Whether a point below the box lies under a bottom face (it left the region downward, into the coarse
  // level's part of the vessel); false without an open bottom.
  bool below_a_bottom_face(const Vec3& x) const;
  bool has_bottom_faces() const { return bottom_faces_ > 0; }

 private:
  // Where a point lies beyond the box: not at all (inside it or only below it), above the top, or beside a side
  // (face: that side's boundary face of the cell next to the point, -1 if none).
  struct Beyond {
    enum Where { Not, Above, Beside, Below } where = Not;  // Below: only under a bottom face
    int face = -1;
  };
  Beyond beyond(const Vec3& x) const;
  void add_face(uint32_t c, Side s);  // boundary face on side s of active cell c, numbered next

  CouplingGrid g_;
  std::vector<uint32_t> cells_;
  std::vector<int> face_of_cell_;
  std::vector<size_t> faces_;  // cell of each face
  std::vector<Side> side_;     // side of each face
  size_t top_faces_ = 0;
  std::vector<Side> open_sides_;
  std::vector<int> side_lookup_;  // 5 per active cell: its side faces (XLo, XHi, YLo, YHi, Bottom) or -1
  size_t bottom_faces_ = 0;
  std::vector<int> lookup_;  // flat index -> active cell or -1
  Vec3 hi_;                  // box_hi()
  double inv_h_ = 0.0;       // 1 / cell size (locate(), face_column())
  std::vector<int> column_;  // per column i + nx j: its top face or -1
};

// x lies within `band` of the box [lo, hi], axis by axis (the box grown by band); with_z = false checks the
// column over the box's footprint only. The candidate lists of the level's coupling (crossings, the grid's
// particles) are built with it at each neighbour-list rebuild, band = the skin.
inline bool near_box(const Vec3& x, const Vec3& lo, const Vec3& hi, double band, bool with_z = true) {
  return x.x >= lo.x - band && x.x <= hi.x + band && x.y >= lo.y - band && x.y <= hi.y + band &&
         (!with_z || (x.z >= lo.z - band && x.z <= hi.z + band));
}

}  // namespace mlcg::bus
