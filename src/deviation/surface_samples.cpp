// Step 5 of the outer surface: the deposit -> mesh points on the beads' true outlines. A face
// placed on the side of a bead gives way to points laid on that bead's stadium section, where
// the section is exposed: around the faces, and on to where another bead covers it, so the
// cusp between two stacked beads (narrower than a voxel, where no face exists) is sampled.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>
#include <span>
#include <utility>
#include <vector>

#include "deviation/outer_surface.hpp"
#include "deviation/surface_internal.hpp"

namespace printtwin {

namespace {

constexpr double kPi = std::numbers::pi;
/// A point this close to another bead (mm) is covered by it: two beads' coincident flats
/// (a layer on the one below) cover each other.
constexpr double kCoverMm = 1e-5;
/// Rows of a bead's side per point along the move. A straight bead's surface is the same all
/// along it: where a cell of the outline is exposed in each row of a block, one point at the
/// block's middle carries the block's area (the cell's length times the block's), else each
/// exposed row keeps its own point. The rows (two voxels long) decide what is exposed; a
/// block of rows is a group of the closest-point search.
constexpr int kRowsPerPoint = 2;
/// The edge of the cells that find the beads near a bead (mm).
constexpr double kGridCellMm = 0.5;

/// A bead's frame: its core's centre line (h / 2 below the nozzle tip) from a along d, the
/// level unit vector across it, the unit vector up its section, and the section's sizes.
/// Made only by of() (no member initialisers: the frames are written once, in parallel).
struct BeadFrame {
  Vec3 a, d, dir, across, up;
  double len, half, r;

  static BeadFrame of(const SurfaceBead& b) {
    BeadFrame f;
    f.dir = Vec3::Zero();
    f.across = Vec3::Zero();
    f.up = Vec3::UnitZ();
    f.r = 0.5 * b.height_mm;
    f.half = 0.5 * std::max(0.0, static_cast<double>(b.width_mm) - b.height_mm);
    f.a = b.start_mm - Vec3(0, 0, f.r);
    f.d = b.end_mm - b.start_mm;
    f.len = f.d.norm();
    const Vec3 across(-f.d.y(), f.d.x(), 0.0);
    if (f.len > 0 && across.norm() > 0) {
      f.dir = f.d / f.len;
      f.across = across.normalized();
      f.up = f.dir.cross(f.across);
    }
    return f;
  }
  [[nodiscard]] double reach() const { return half + r; }
};

/// Half circles of at most this many cells find a direction's cell without atan2.
constexpr int kMaxArcCells = 32;
/// The boundaries between the cells of a half circle cut into n equal arcs from -pi/2 to
/// pi/2: boundary j (0 < j < n) points along (sin(j pi / n), -cos(j pi / n)).
struct ArcBoundaries {
  std::array<double, kMaxArcCells> sin_j{}, cos_j{};
};
const ArcBoundaries& arc_boundaries(int n) {
  static const std::array<ArcBoundaries, kMaxArcCells + 1> table = [] {
    std::array<ArcBoundaries, kMaxArcCells + 1> t{};
    for (std::size_t m = 1; m <= kMaxArcCells; ++m)
      for (std::size_t j = 1; j < m; ++j) {
        const double a = static_cast<double>(j) * kPi / static_cast<double>(m);
        t[m].sin_j[j] = std::sin(a);
        t[m].cos_j[j] = std::cos(a);
      }
    return t;
  }();
  return table[static_cast<std::size_t>(n)];
}
/// The cell of direction (x, z), x >= 0, on a half circle of n cells from -pi/2 to pi/2
/// (clamp(int(n (atan2(z, x) + pi / 2) / pi), 0, n - 1)) as the number of boundaries the
/// direction lies past (found by bisection: that side changes once along the half circle),
/// when it lies clear of the cell's own boundaries by far more than the rounding of either
/// computation (1e-9 of |x| + |z|): then both give the same cell, and every other boundary
/// lies at least pi / n away. Else -1 (the caller uses atan2).
int half_circle_cell(int n, double x, double z) {
  if (n > kMaxArcCells) return -1;
  const ArcBoundaries& b = arc_boundaries(n);
  // |(x, z)| sin(angle past boundary j)
  const auto side = [&](int j) {
    const auto k = static_cast<std::size_t>(j);
    return b.sin_j[k] * z + b.cos_j[k] * x;
  };
  int lo = 0, hi = n - 1;  // the cell is in [lo, hi]
  while (lo < hi) {
    const int mid = (lo + hi + 1) / 2;  // past boundary mid: the cell is mid or above
    if (side(mid) > 0)
      lo = mid;
    else
      hi = mid - 1;
  }
  const double margin = 1e-9 * (std::abs(x) + std::abs(z));
  if (lo > 0 && !(std::abs(side(lo)) > margin)) return -1;
  if (lo + 1 < n && !(std::abs(side(lo + 1)) > margin)) return -1;
  return lo;
}

/// The stadium section as cells of the outline: the right round side (n_arc cells, from the
/// bottom up), the top flat (n_flat, right to left), the left round side (top down), the
/// bottom flat (left to right).
struct Section {
  int n_arc = 1, n_flat = 0;
  double half = 0, r = 0;

  Section(const BeadFrame& f, double arc_step, double flat_step) : half(f.half), r(f.r) {
    n_arc = std::max(8, static_cast<int>(std::ceil(kPi * r / arc_step)));
    n_flat = half > 0 ? std::max(1, static_cast<int>(std::ceil(2 * half / flat_step))) : 0;
  }
  [[nodiscard]] int cells() const { return 2 * n_arc + 2 * n_flat; }
  /// Cell c's centre as (across, up) offsets from the centre line, and its length.
  void cell(int c, double& s, double& z, double& len) const {
    const double arc_len = kPi * r / n_arc, flat_len = n_flat > 0 ? 2 * half / n_flat : 0;
    if (c < n_arc) {
      const double t = -0.5 * kPi + (c + 0.5) * kPi / n_arc;
      s = half + r * std::cos(t), z = r * std::sin(t), len = arc_len;
    } else if (c < n_arc + n_flat) {
      s = half - (c - n_arc + 0.5) * flat_len, z = r, len = flat_len;
    } else if (c < 2 * n_arc + n_flat) {
      const double t = 0.5 * kPi + (c - n_arc - n_flat + 0.5) * kPi / n_arc;
      s = -half + r * std::cos(t), z = r * std::sin(t), len = arc_len;
    } else {
      s = -half + (c - 2 * n_arc - n_flat + 0.5) * flat_len, z = -r, len = flat_len;
    }
  }
  /// The cell holding the outline point at offsets (s, z).
  [[nodiscard]] int cell_of(double s, double z) const {
    const auto in = [](double x, int n) { return std::clamp(static_cast<int>(x * n), 0, n - 1); };
    if (s >= half) {
      const int c = half_circle_cell(n_arc, s - half, z);
      return c >= 0 ? c : in((std::atan2(z, s - half) + 0.5 * kPi) / kPi, n_arc);
    }
    if (s <= -half) {
      // From the top down: the cell of the opposite direction on the right side.
      if (const int c = half_circle_cell(n_arc, -(s + half), -z); c >= 0) return n_arc + n_flat + c;
      double t = std::atan2(z, s + half);
      if (t < 0) t += 2 * kPi;
      return n_arc + n_flat + in((t - 0.5 * kPi) / kPi, n_arc);
    }
    if (z >= 0) return n_arc + in((half - s) / (2 * half), n_flat);
    return 2 * n_arc + n_flat + in((s + half) / (2 * half), n_flat);
  }
};

/// A round cap's half section, revolved half a turn about the vertical through the core's end
/// point: the bottom flat from the axis out (n_flat cells), the round side from the bottom up
/// (the side's n_arc cells), the top flat back to the axis. Cell centres are (radius from the
/// axis, height from the core) offsets; an open chain (past either end lies the other half of
/// the cap, or the bead).
struct CapSection {
  int n_flat = 0, n_arc = 1;
  double half = 0, r = 0;

  CapSection(const Section& side, double flat_step)
      : n_arc(side.n_arc), half(side.half), r(side.r) {
    n_flat = half > 0 ? std::max(1, static_cast<int>(std::ceil(half / flat_step))) : 0;
  }
  [[nodiscard]] int cells() const { return 2 * n_flat + n_arc; }
  void cell(int c, double& rho, double& z, double& len) const {
    const double flat_len = n_flat > 0 ? half / n_flat : 0;
    if (c < n_flat) {
      rho = (c + 0.5) * flat_len, z = -r, len = flat_len;
    } else if (c < n_flat + n_arc) {
      const double t = -0.5 * kPi + (c - n_flat + 0.5) * kPi / n_arc;
      rho = half + r * std::cos(t), z = r * std::sin(t), len = kPi * r / n_arc;
    } else {
      rho = half - (c - n_flat - n_arc + 0.5) * flat_len, z = r, len = flat_len;
    }
  }
  [[nodiscard]] int cell_of(double rho, double z) const {
    const auto in = [](double x, int n) { return std::clamp(static_cast<int>(x * n), 0, n - 1); };
    if (rho > half || n_flat == 0) {
      const int c = half_circle_cell(n_arc, rho - half, z);
      return n_flat + (c >= 0 ? c : in((std::atan2(z, rho - half) + 0.5 * kPi) / kPi, n_arc));
    }
    return z < 0 ? in(rho / half, n_flat) : n_flat + n_arc + in((half - rho) / half, n_flat);
  }
};

/// Squared distance between segments [p, p + u] and [q, q + w].
double segment_distance2(const Vec3& p, const Vec3& u, const Vec3& q, const Vec3& w) {
  const Vec3 r = p - q;
  const double a = u.squaredNorm(), e = w.squaredNorm(), f = w.dot(r);
  double s = 0, t = 0;
  if (a <= 1e-18 && e <= 1e-18) return r.squaredNorm();
  if (a <= 1e-18) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = u.dot(r);
    if (e <= 1e-18) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = u.dot(w), den = a * e - b * b;
      s = den > 1e-18 ? std::clamp((b * f - c * e) / den, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0, s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1, s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return (p + s * u - (q + t * w)).squaredNorm();
}

/// The beads by the cells (edge `cell_mm`, a dense grid over the beads' box) their outlines
/// reach, for the beads near a bead: a bead is listed in every cell within its reach of its
/// centre line, so two beads whose outlines may touch share a cell.
class BeadGrid {
 public:
  BeadGrid(std::span<const BeadFrame> frames, std::span<const std::uint32_t> listed, double cell_mm)
      : cell_(cell_mm) {
    Box3 box;
    for (const std::uint32_t k : listed) {
      box.extend(frames[k].a);
      box.extend(frames[k].a + frames[k].d);
    }
    if (box.empty()) return;
    // The grid covers the box with a cell of margin; no more than 2^24 cells.
    const Vec3 size = box.size() + Vec3::Constant(4 * cell_);
    while (size.x() / cell_ * (size.y() / cell_) * (size.z() / cell_) > double(1 << 24)) cell_ *= 2;
    lo_ = box.min - Vec3::Constant(2 * cell_);
    for (int i = 0; i < 3; ++i) n_[i] = static_cast<int>(std::ceil(size[i] / cell_)) + 1;
    begin_.assign(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2] + 1, 0);
    std::vector<std::uint32_t> keys;
    for (const std::uint32_t k : listed) {
      cells_of(frames[k], keys);
      for (const std::uint32_t c : keys) ++begin_[c + 1];
    }
    for (std::size_t c = 1; c < begin_.size(); ++c) begin_[c] += begin_[c - 1];
    beads_.resize(begin_.back());
    std::vector<std::uint32_t> fill(begin_.begin(), begin_.end() - 1);
    for (const std::uint32_t k : listed) {
      cells_of(frames[k], keys);
      for (const std::uint32_t c : keys) beads_[fill[c]++] = k;
    }
  }
  /// A thread's marks of the beads already listed, and its cell list.
  struct Seen {
    std::vector<std::uint32_t> stamp;
    std::uint32_t now = 0;
    std::vector<std::uint32_t> keys;
  };
  /// The beads sharing a cell with f, each once.
  void near(const BeadFrame& f, std::vector<std::uint32_t>& out, Seen& seen) const {
    if (begin_.empty()) return;
    std::vector<std::uint32_t>& keys = seen.keys;
    cells_of(f, keys);
    if (++seen.now == 0) {  // the stamps wrapped round
      std::fill(seen.stamp.begin(), seen.stamp.end(), 0);
      seen.now = 1;
    }
    for (const std::uint32_t c : keys)
      for (std::uint32_t j = begin_[c]; j < begin_[c + 1]; ++j)
        if (seen.stamp[beads_[j]] != seen.now) {
          seen.stamp[beads_[j]] = seen.now;
          out.push_back(beads_[j]);
        }
  }

 private:
  /// The cells within f's reach of its centre line: the centre line in pieces of at most two
  /// cells, each piece's box grown by the reach; each cell once (in no set order). The
  /// pieces' boxes move monotonically along each axis (the line is straight and the rounding
  /// monotonic), so a cell in two boxes is in every box between them: a piece skips the
  /// cells of the piece before it, and no sort is needed.
  void cells_of(const BeadFrame& f, std::vector<std::uint32_t>& keys) const {
    keys.clear();
    const int pieces = 1 + static_cast<int>(f.len / (2 * cell_));
    const double pad = f.reach() + kCoverMm;
    const auto c = [&](double x, int axis) {
      return std::clamp(static_cast<int>(std::floor((x - lo_[axis]) / cell_)), 0, n_[axis] - 1);
    };
    Eigen::Vector3i prev_lo(1, 1, 1), prev_hi(0, 0, 0);  // empty before the first piece
    for (int i = 0; i < pieces; ++i) {
      const Vec3 p = f.a + (static_cast<double>(i) / pieces) * f.d;
      const Vec3 q = f.a + (static_cast<double>(i + 1) / pieces) * f.d;
      const Vec3 lo = p.cwiseMin(q) - Vec3::Constant(pad), hi = p.cwiseMax(q) + Vec3::Constant(pad);
      const Eigen::Vector3i l(c(lo.x(), 0), c(lo.y(), 1), c(lo.z(), 2)),
          h(c(hi.x(), 0), c(hi.y(), 1), c(hi.z(), 2));
      const auto in_prev = [&](int axis, int x) {
        return x >= prev_lo[axis] && x <= prev_hi[axis];
      };
      for (int x = l.x(); x <= h.x(); ++x)
        for (int y = l.y(); y <= h.y(); ++y)
          for (int z = l.z(); z <= h.z(); ++z)
            if (!(in_prev(0, x) && in_prev(1, y) && in_prev(2, z)))
              keys.push_back(static_cast<std::uint32_t>((x * n_[1] + y) * n_[2] + z));
      prev_lo = l;
      prev_hi = h;
    }
  }
  double cell_;
  Vec3 lo_ = Vec3::Zero();
  std::array<int, 3> n_{};
  std::vector<std::uint32_t> begin_, beads_;
};

/// A cell of a bead's outline: its centre's offsets across and up from the centre line, and
/// its length round the outline.
struct OutlineCell {
  double s = 0, z = 0, len = 0;
};
/// A bead that may cover another's outline: the span of the other's centre line it may cover
/// (length along it), the heights it may cover, its level box (its core's box grown by its
/// radius and kCoverMm, with a margin for rounding) and its slab across (its core lies within
/// `half` of its centre line across the move): a point outside the box or the slab grown by
/// the radius and kCoverMm lies farther than kCoverMm from the bead.
struct NearBead {
  std::uint32_t bead;
  double u0, u1, z0, z1, x0, x1, y0, y1;
  Vec3 a, across;  ///< the bead's centre line start and its level unit vector across
  double slab;     ///< half + r + kCoverMm, with a margin for rounding
  /// Whether p lies outside the box or the slab (so not within kCoverMm of the bead).
  [[nodiscard]] bool clear_of(const Vec3& p) const {
    return p.z() < z0 || p.z() > z1 || p.x() < x0 || p.x() > x1 || p.y() < y0 || p.y() > y1 ||
           std::abs((p - a).dot(across)) > slab;
  }
};
/// A thread's working memory for laying beads (reused from bead to bead).
struct Scratch {
  BeadGrid::Seen seen;
  std::vector<OutlineCell> cell;
  std::vector<std::uint8_t> marked, exposed, cap_marked;
  std::vector<std::int8_t> covered;
  std::vector<NearBead> near;
  std::vector<const NearBead*> active;
  std::vector<Vec3> points;  ///< the points of the bead's faces (PlacedFaces), in their order
  /// The cells of a section (Section or CapSection), as `cell`.
  template <class S>
  const std::vector<OutlineCell>& cells_of(const S& sec) {
    cell.resize(static_cast<std::size_t>(sec.cells()));
    for (std::size_t c = 0; c < cell.size(); ++c)
      sec.cell(static_cast<int>(c), cell[c].s, cell[c].z, cell[c].len);
    return cell;
  }
  /// The near beads that may cover the span [u0, u1] of the centre line, as `active`.
  void activate(double u0, double u1) {
    active.clear();
    for (const NearBead& x : near)
      if (x.u0 <= u1 && x.u1 >= u0) active.push_back(&x);
  }
};

/// The points a run of consecutive sampled beads lays, bead after bead, with the beads that
/// touch each; chunks are concatenated in order, so the output does not depend on the threads.
struct ChunkPoints {
  std::vector<Vec3> p;
  std::vector<double> area;
  std::vector<std::uint32_t> group;  ///< start of each group, in the chunk's points
  std::vector<std::uint32_t> touch;
  std::vector<std::uint32_t> point_end, touch_end;  ///< per bead of the chunk
  std::vector<VoxelTag> tag;                        ///< per bead of the chunk
};
/// Sampled beads per chunk.
constexpr std::size_t kBeadsPerChunk = 32;

/// What the beads' sampling shares.
struct Sampler {
  std::span<const SurfaceBead> beads;
  std::span<const BeadFrame> frames;
  const std::vector<detail::BeadCore>& cores;
  const BeadGrid& grid;
  const detail::PlacedFaces& placed;
  double arc_step, along_step;

  /// Whether the outlines of bead k's centre line from `from` along `along` and of bead c
  /// may touch.
  [[nodiscard]] bool may_touch(const BeadFrame& f, const Vec3& from, const Vec3& along,
                               std::uint32_t c) const {
    const BeadFrame& g = frames[c];
    const double reach = f.reach() + g.reach() + kCoverMm;
    return segment_distance2(from, along, g.a, g.d) <= reach * reach;
  }
  /// The beads whose outline may touch bead k's, in index order, appended to `touch`.
  void touching(std::uint32_t k, std::vector<std::uint32_t>& touch, BeadGrid::Seen& seen) const {
    const BeadFrame& f = frames[k];
    const std::size_t from = touch.size();
    grid.near(f, touch, seen);
    const auto first = touch.begin() + static_cast<std::ptrdiff_t>(from);
    touch.erase(
        std::remove_if(first, touch.end(),
                       [&](std::uint32_t c) { return c == k || !may_touch(f, f.a, f.d, c); }),
        touch.end());
    std::sort(touch.begin() + static_cast<std::ptrdiff_t>(from), touch.end());
  }

  [[nodiscard]] bool covered(std::uint32_t k, const Vec3& p,
                             std::span<const NearBead* const> active) const;
  void lay(std::uint32_t k, std::span<const std::uint32_t> faces, double ext_extra, Scratch& w,
           ChunkPoints& out) const;
  /// The points on bead k's round caps, where its faces' points (w.points, as lay found
  /// them) lie past its ends.
  void lay_caps(std::uint32_t k, const Section& sec, double ext, Scratch& w,
                ChunkPoints& out) const;
};

/// Marks exposed[c] for the cells of one row of an outline: each marked cell that is not
/// covered, and from it both ways along the row (round it when `cyclic`) up to `ext` of
/// length, until a covered or a marked cell.
template <class Covered>
void expose_row(const std::uint8_t* mk, int m, bool cyclic, const std::vector<OutlineCell>& cell,
                double ext, const Covered& is_covered, std::uint8_t* exposed) {
  for (int c = 0; c < m; ++c) {
    if (mk[c] == 0 || is_covered(c)) continue;
    exposed[static_cast<std::size_t>(c)] = 1;
    for (const int step : {1, -1}) {  // both ways along the row
      double acc = 0;
      for (int j = c + step, n = 1; n < m; j += step, ++n) {
        if (cyclic) j = (j + m) % m;
        if (j < 0 || j >= m || mk[j] != 0) break;
        const double len = cell[static_cast<std::size_t>(j)].len;
        if (acc + len > ext + 1e-12 || is_covered(j)) break;
        acc += len;
        exposed[static_cast<std::size_t>(j)] = 1;
      }
    }
  }
}

/// The outline point of cell c at length u along f's centre line.
Vec3 point_at(const BeadFrame& f, const std::vector<OutlineCell>& cell, int c, double u) {
  const OutlineCell& x = cell[static_cast<std::size_t>(c)];
  const Vec3 q0 = f.a + u * f.dir;
  return q0 + x.s * f.across + x.z * f.up;
}

/// Whether point p of bead k's outline is covered by one of the `active` beads: inside it, or
/// on its surface where that surface is another bead's contact face (the normals oppose: a
/// layer on the one below) or is the same surface owned by a lower bead (two round ends that
/// meet: one of them samples it).
bool Sampler::covered(std::uint32_t k, const Vec3& p,
                      std::span<const NearBead* const> active) const {
  Vec3 core;
  for (const NearBead* x : active) {
    if (x->clear_of(p)) continue;
    const double sd = cores[x->bead].closest(p, core);
    if (sd < -kCoverMm) return true;
    if (sd > kCoverMm) continue;
    if (x->bead < k) return true;
    Vec3 own;
    cores[k].closest(p, own);
    if ((p - own).dot(p - core) < 0) return true;
  }
  return false;
}

void Sampler::lay(std::uint32_t k, std::span<const std::uint32_t> faces, double ext_extra,
                  Scratch& w, ChunkPoints& out) const {
  const BeadFrame& f = frames[k];
  const Section sec(f, arc_step, along_step);
  const int m = sec.cells();
  const auto mm = static_cast<std::size_t>(m);
  const std::vector<OutlineCell>& cell = w.cells_of(sec);
  const int rows = std::max(1, static_cast<int>(std::ceil(f.len / along_step)));
  const double du = f.len / rows;
  std::vector<std::uint8_t>& marked = w.marked;
  marked.assign(static_cast<std::size_t>(rows) * mm, 0);
  bool capped = false;  // a face lies past an end, on a round cap
  std::vector<Vec3>& points = w.points;
  points.resize(faces.size());
  for (std::size_t j = 0; j < faces.size(); ++j) points[j] = placed.point(faces[j]);
  for (const Vec3& q : points) {
    const Vec3 rel = q - f.a;
    const double u = rel.dot(f.dir);
    if (!(u > 0 && u < f.len)) {
      capped = true;
      continue;
    }
    const int row = std::clamp(static_cast<int>(u / du), 0, rows - 1);
    marked[static_cast<std::size_t>(row) * mm + sec.cell_of(rel.dot(f.across), rel.dot(f.up))] = 1;
  }
  const std::size_t touch_from = out.touch.size();
  touching(k, out.touch, w.seen);
  const std::span<const std::uint32_t> touch(out.touch.data() + touch_from,
                                             out.touch.size() - touch_from);
  // Each touching bead: the span of k's centre line it may cover and the heights it may cover.
  std::vector<NearBead>& near = w.near;
  near.clear();
  for (const std::uint32_t c : touch) {
    const BeadFrame& g = frames[c];
    const double t0 = (g.a - f.a).dot(f.dir), t1 = (g.a + g.d - f.a).dot(f.dir);
    const double pad = f.reach() + g.reach() + kCoverMm, rz = g.r + kCoverMm;
    const double za = g.a.z(), zb = g.a.z() + g.d.z();
    // The core lies within its centre line's box grown by its half width across (level).
    const double rxy = g.half + g.r + kCoverMm + 1e-9;
    const Vec3 b = g.a + g.d;
    near.push_back({c, std::min(t0, t1) - pad, std::max(t0, t1) + pad, std::min(za, zb) - rz,
                    std::max(za, zb) + rz, std::min(g.a.x(), b.x()) - rxy,
                    std::max(g.a.x(), b.x()) + rxy, std::min(g.a.y(), b.y()) - rxy,
                    std::max(g.a.y(), b.y()) + rxy, g.a, g.across, rxy});
  }
  std::vector<const NearBead*>& active = w.active;
  // The outline extends past its faces by up to a quarter circle and a voxel.
  const double ext = 0.5 * kPi * f.r + ext_extra;
  std::vector<std::int8_t>& covered_memo = w.covered;
  std::vector<std::uint8_t>& exposed = w.exposed;
  covered_memo.resize(mm);
  exposed.resize(kRowsPerPoint * mm);
  const std::size_t group_from = out.group.size();
  for (int r0 = 0; r0 < rows; r0 += kRowsPerPoint) {
    // The block's rows, each exposed as its own row (the exposed area is the rows' own).
    const int nr = std::min(kRowsPerPoint, rows - r0);
    bool any = false;
    for (int j = 0; j < nr; ++j) {
      std::uint8_t* ex = &exposed[static_cast<std::size_t>(j) * mm];
      std::fill(ex, ex + m, 0);
      const std::uint8_t* mk = &marked[static_cast<std::size_t>(r0 + j) * mm];
      if (std::none_of(mk, mk + m, [](std::uint8_t x) { return x != 0; })) continue;
      any = true;
      const double u = (r0 + j + 0.5) * du;
      w.activate(u - 0.5 * du, u + 0.5 * du);
      std::fill(covered_memo.begin(), covered_memo.end(), -1);
      const auto is_covered = [&](int c) {
        auto& memo = covered_memo[static_cast<std::size_t>(c)];
        if (memo < 0) memo = covered(k, point_at(f, cell, c, u), active) ? 1 : 0;
        return memo != 0;
      };
      expose_row(mk, m, true, cell, ext, is_covered, ex);
    }
    if (!any) continue;
    out.group.push_back(static_cast<std::uint32_t>(out.p.size()));
    // A cell exposed in every row of the block: one point at the block's middle, weighted by
    // the block's length; else a point per exposed row.
    for (int c = 0; c < m; ++c) {
      int n = 0;
      for (int j = 0; j < nr; ++j) n += exposed[static_cast<std::size_t>(j) * mm + c];
      if (n == 0) continue;
      const double len = cell[static_cast<std::size_t>(c)].len;
      if (n == nr) {
        out.p.push_back(point_at(f, cell, c, (r0 + 0.5 * nr) * du));
        out.area.push_back(len * nr * du);
        continue;
      }
      for (int j = 0; j < nr; ++j)
        if (exposed[static_cast<std::size_t>(j) * mm + c] != 0) {
          out.p.push_back(point_at(f, cell, c, (r0 + j + 0.5) * du));
          out.area.push_back(len * du);
        }
    }
  }
  if (capped) lay_caps(k, sec, ext, w, out);
  if (out.group.size() > group_from && out.group.back() == out.p.size()) out.group.pop_back();
  out.point_end.push_back(static_cast<std::uint32_t>(out.p.size()));
  out.touch_end.push_back(static_cast<std::uint32_t>(out.touch.size()));
}

void Sampler::lay_caps(std::uint32_t k, const Section& sec, double ext, Scratch& w,
                       ChunkPoints& out) const {
  const BeadFrame& f = frames[k];
  if (f.across.x() == 0 && f.across.y() == 0) return;  // a vertical move: no level cap
  const CapSection cap(sec, along_step);
  const int m = cap.cells();
  const auto mm = static_cast<std::size_t>(m);
  const std::vector<OutlineCell>& cell = w.cells_of(cap);
  // Azimuth rows of at most a row's length at the cap's rim, from its right round to its left.
  const int n_az = std::max(4, static_cast<int>(std::ceil(kPi * f.reach() / along_step)));
  const double dphi = kPi / n_az;
  const Vec3 dir_h = Vec3(f.d.x(), f.d.y(), 0.0).normalized();
  std::vector<std::uint8_t>& marked = w.cap_marked;
  marked.assign(2 * static_cast<std::size_t>(n_az) * mm, 0);
  // Cap e (0 = start, 1 = end): its centre, outward and leftward directions.
  const auto frame = [&](int e, Vec3& centre, Vec3& out_dir, Vec3& left) {
    centre = e == 0 ? f.a : Vec3(f.a + f.d);
    out_dir = e == 0 ? Vec3(-dir_h) : dir_h;
    left = e == 0 ? Vec3(-f.across) : f.across;
  };
  for (const Vec3& q : w.points) {
    const double u = (q - f.a).dot(f.dir);
    if (u > 0 && u < f.len) continue;
    const int e = u <= 0 ? 0 : 1;
    Vec3 centre, out_dir, left;
    frame(e, centre, out_dir, left);
    const Vec3 rel = q - centre;
    const Vec3 g(rel.x(), rel.y(), 0.0);
    const double phi = std::clamp(std::atan2(g.dot(left), g.dot(out_dir)), -0.5 * kPi, 0.5 * kPi);
    const int az = std::clamp(static_cast<int>((phi + 0.5 * kPi) / dphi), 0, n_az - 1);
    marked[(static_cast<std::size_t>(e) * n_az + az) * mm + cap.cell_of(g.norm(), rel.z())] = 1;
  }
  std::vector<std::int8_t>& covered_memo = w.covered;
  std::vector<std::uint8_t>& exposed = w.exposed;
  covered_memo.resize(mm);
  exposed.resize(mm);
  for (int e = 0; e < 2; ++e) {
    Vec3 centre, out_dir, left;
    frame(e, centre, out_dir, left);
    bool grouped = false;
    for (int az = 0; az < n_az; ++az) {
      const std::uint8_t* mk = &marked[(static_cast<std::size_t>(e) * n_az + az) * mm];
      if (std::none_of(mk, mk + m, [](std::uint8_t x) { return x != 0; })) continue;
      const double phi = -0.5 * kPi + (az + 0.5) * dphi;
      const Vec3 radial = std::cos(phi) * out_dir + std::sin(phi) * left;
      if (e == 0)
        w.activate(-f.reach(), 0.0);
      else
        w.activate(f.len, f.len + f.reach());
      std::fill(covered_memo.begin(), covered_memo.end(), -1);
      std::fill(exposed.begin(), exposed.end(), 0);
      const auto point = [&](int c) {
        const OutlineCell& x = cell[static_cast<std::size_t>(c)];
        return Vec3(centre + x.s * radial + Vec3(0, 0, x.z));
      };
      const auto is_covered = [&](int c) {
        auto& memo = covered_memo[static_cast<std::size_t>(c)];
        if (memo < 0) memo = covered(k, point(c), w.active) ? 1 : 0;
        return memo != 0;
      };
      expose_row(mk, m, false, cell, ext, is_covered, exposed.data());
      if (!grouped) out.group.push_back(static_cast<std::uint32_t>(out.p.size()));
      grouped = true;
      for (int c = 0; c < m; ++c) {
        if (exposed[static_cast<std::size_t>(c)] == 0) continue;
        const OutlineCell& x = cell[static_cast<std::size_t>(c)];
        out.p.push_back(point(c));
        out.area.push_back(x.len * x.s * dphi);
      }
    }
  }
}

/// The faces on a bead's side (not past its ends), which give way to the bead's outline, by
/// bead: faces of bead k are by_bead[begin[k] .. begin[k + 1]), in face order.
struct ReplacedFaces {
  std::vector<std::uint8_t> replaced;  ///< per face
  std::vector<std::uint32_t> begin, by_bead;
};
ReplacedFaces replaced_faces(const DepositSurface& s, std::span<const BeadFrame> frames,
                             const detail::PlacedFaces& placed) {
  const std::size_t n = s.faces.size();
  ReplacedFaces r;
  r.replaced.resize(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1 << 14),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const std::uint32_t k = s.face_bead[i];
                        bool on_bead = false;
                        if (k != kNoBead && frames[k].len > 0) {
                          const BeadFrame& f = frames[k];
                          // Past an end of a level bead: on its round cap. The point is
                          // needed only for a vertical move's.
                          on_bead = f.across.x() != 0 || f.across.y() != 0;
                          if (!on_bead) {
                            const double u = (placed.point(i) - f.a).dot(f.dir);
                            on_bead = u > 0 && u < f.len;
                          }
                        }
                        r.replaced[i] = on_bead ? 1 : 0;
                      }
                    });
  r.begin.assign(frames.size() + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (r.replaced[i] != 0) ++r.begin[s.face_bead[i] + 1];
  for (std::size_t k = 0; k < frames.size(); ++k) r.begin[k + 1] += r.begin[k];
  r.by_bead.resize(r.begin.back());
  std::vector<std::uint32_t> fill(r.begin.begin(), r.begin.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    if (r.replaced[i] != 0) r.by_bead[fill[s.face_bead[i]]++] = static_cast<std::uint32_t>(i);
  return r;
}

/// The output lists sized for `kept` faces' points and the chunks' points, written in
/// parallel: the faces kept, in their cell order (a cell's kept faces one group), then the
/// beads' points in bead order.
void assemble(DepositSurface& s, const ReplacedFaces& faces, const detail::PlacedFaces& placed,
              std::span<const std::uint32_t> sampled, const std::vector<ChunkPoints>& chunks,
              std::size_t n_beads) {
  const std::size_t n_cells = s.face_cell_begin.empty() ? 0 : s.face_cell_begin.size() - 1;
  // Per cell: its kept faces; then where its points and group start.
  std::vector<std::uint32_t> kept(n_cells + 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n_cells, 1 << 12),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        std::uint32_t x = 0;
                        for (std::uint32_t i = s.face_cell_begin[c]; i < s.face_cell_begin[c + 1];
                             ++i)
                          x += faces.replaced[i] == 0 ? 1 : 0;
                        kept[c + 1] = x;
                      }
                    });
  std::vector<std::uint32_t> cell_group(n_cells + 1, 0);
  for (std::size_t c = 0; c < n_cells; ++c) {
    cell_group[c + 1] = cell_group[c] + (kept[c + 1] > 0 ? 1 : 0);
    kept[c + 1] += kept[c];
  }
  // Per chunk: where its points, groups and touch lists start.
  const std::size_t nc = chunks.size();
  std::vector<std::size_t> p0(nc + 1, kept[n_cells]), g0(nc + 1, cell_group[n_cells]),
      t0(nc + 1, 0);
  for (std::size_t c = 0; c < nc; ++c) {
    p0[c + 1] = p0[c] + chunks[c].p.size();
    g0[c + 1] = g0[c] + chunks[c].group.size();
    t0[c + 1] = t0[c] + chunks[c].touch.size();
  }
  // Sized side by side (resize writes each element's initial value).
  tbb::parallel_invoke([&] { s.points_mm.resize(p0[nc]); },
                       [&] { s.point_area_mm2.resize(p0[nc]); },
                       [&] { s.point_tags.resize(p0[nc]); },
                       [&] {
                         s.point_groups.resize(g0[nc] + 1);
                         s.bead_touch.resize(t0[nc]);
                         s.bead_touch_begin.assign(n_beads + 1, 0);
                       });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n_cells, 1 << 12),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        std::size_t o = kept[c];
                        if (kept[c + 1] > o) s.point_groups[cell_group[c]] = kept[c];
                        for (std::uint32_t i = s.face_cell_begin[c]; i < s.face_cell_begin[c + 1];
                             ++i) {
                          if (faces.replaced[i] != 0) continue;
                          s.points_mm[o] = placed.point(i, &s.point_area_mm2[o]);
                          s.point_tags[o] = s.face_tags[i];
                          ++o;
                        }
                      }
                    });
  tbb::parallel_for(std::size_t{0}, nc, [&](std::size_t c) {
    const ChunkPoints& x = chunks[c];
    std::copy(x.p.begin(), x.p.end(), s.points_mm.begin() + static_cast<std::ptrdiff_t>(p0[c]));
    std::copy(x.area.begin(), x.area.end(),
              s.point_area_mm2.begin() + static_cast<std::ptrdiff_t>(p0[c]));
    for (std::size_t g = 0; g < x.group.size(); ++g)
      s.point_groups[g0[c] + g] = static_cast<std::uint32_t>(p0[c] + x.group[g]);
    std::copy(x.touch.begin(), x.touch.end(),
              s.bead_touch.begin() + static_cast<std::ptrdiff_t>(t0[c]));
    std::uint32_t pb = 0, tb = 0;
    for (std::size_t j = 0; j < x.tag.size(); ++j) {
      std::fill(s.point_tags.begin() + static_cast<std::ptrdiff_t>(p0[c] + pb),
                s.point_tags.begin() + static_cast<std::ptrdiff_t>(p0[c] + x.point_end[j]),
                x.tag[j]);
      pb = x.point_end[j];
      s.bead_touch_begin[sampled[c * kBeadsPerChunk + j] + 1] = x.touch_end[j] - tb;
      tb = x.touch_end[j];
    }
  });
  s.point_groups.back() = static_cast<std::uint32_t>(p0[nc]);
  for (std::size_t k = 0; k < n_beads; ++k) s.bead_touch_begin[k + 1] += s.bead_touch_begin[k];
}

}  // namespace

void sample_bead_outlines(DepositSurface& s, std::span<const SurfaceBead> beads,
                          std::span<const std::uint8_t> placed) {
  const detail::BeadIndex index(beads);
  detail::sample_bead_outlines(s, beads, index, placed);
}

void detail::sample_bead_outlines(DepositSurface& s, std::span<const SurfaceBead> beads,
                                  const BeadIndex& index, std::span<const std::uint8_t> placed) {
  const std::vector<detail::BeadCore>& cores = index.cores();
  // Without initial values: each frame is written once, in parallel.
  const auto frame_store = std::make_unique_for_overwrite<BeadFrame[]>(beads.size());
  const std::span<BeadFrame> frames(frame_store.get(), beads.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, beads.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k)
                        frames[k] = BeadFrame::of(beads[k]);
                    });
  const detail::PlacedFaces points{s, beads, cores, placed};
  const ReplacedFaces faces = replaced_faces(s, frames, points);
  std::vector<std::uint32_t> sampled;
  for (std::size_t k = 0; k < beads.size(); ++k)
    if (faces.begin[k + 1] > faces.begin[k]) sampled.push_back(static_cast<std::uint32_t>(k));
  const double v = s.voxel_mm;
  std::vector<ChunkPoints> chunks((sampled.size() + kBeadsPerChunk - 1) / kBeadsPerChunk);
  if (!sampled.empty()) {
    // The beads that may cover a sampled bead's exposed outline: the sampled beads (the
    // layers above and below a wall, the neighbours of a top skin) and their neighbours along
    // the path. A bead no face lies on (an inner perimeter) is not one: the outline extends
    // no further than a quarter circle past its faces.
    std::vector<std::uint32_t> listed;
    for (const std::uint32_t k : sampled)
      for (std::uint32_t c = k > 0 ? k - 1 : k; c <= k + 1 && c < beads.size(); ++c)
        if (listed.empty() || listed.back() < c) listed.push_back(c);
    const BeadGrid grid(frames, listed, kGridCellMm);
    const Sampler sampler{beads, frames, cores, grid, points, v, 2 * v};
    tbb::enumerable_thread_specific<Scratch> scratch_of([&] {
      Scratch w;
      w.seen.stamp.assign(beads.size(), 0);
      return w;
    });
    tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t c) {
      Scratch& w = scratch_of.local();
      ChunkPoints& out = chunks[c];
      const std::size_t j1 = std::min(sampled.size(), (c + 1) * kBeadsPerChunk);
      for (std::size_t j = c * kBeadsPerChunk; j < j1; ++j) {
        const std::uint32_t k = sampled[j];
        const std::span<const std::uint32_t> bead_faces(faces.by_bead.data() + faces.begin[k],
                                                        faces.begin[k + 1] - faces.begin[k]);
        sampler.lay(k, bead_faces, v, w, out);
        // The bead's layer and feature from a face of its own line, if any.
        VoxelTag tag = s.face_tags[bead_faces.front()];
        for (const std::uint32_t i : bead_faces)
          if (s.face_tags[i].line == beads[k].line) {
            tag = s.face_tags[i];
            break;
          }
        tag.line = beads[k].line;
        out.tag.push_back(tag);
      }
    });
  }
  assemble(s, faces, points, sampled, chunks, beads.size());
}

}  // namespace printtwin
