// Step 5 of the outer surface: the deposit -> mesh points on the beads' true outlines. A face
// placed on the side of a bead gives way to points laid on that bead's stadium section, where
// the section is exposed: around the faces, and on to where another bead covers it, so the
// cusp between two stacked beads (narrower than a voxel, where no face exists) is sampled.
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
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
/// Rows of a bead's points per group of the closest-point search.
constexpr int kRowsPerGroup = 2;
/// The edge of the cells that find the beads near a bead (mm).
constexpr double kGridCellMm = 0.5;

/// A bead's frame: its core's centre line (h / 2 below the nozzle tip) from a along d, the
/// level unit vector across it, the unit vector up its section, and the section's sizes.
struct BeadFrame {
  Vec3 a = Vec3::Zero(), d = Vec3::Zero(), dir = Vec3::Zero(), across = Vec3::Zero(),
       up = Vec3::UnitZ();
  double len = 0, half = 0, r = 0;

  static BeadFrame of(const SurfaceBead& b) {
    BeadFrame f;
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
    if (s >= half) return in((std::atan2(z, s - half) + 0.5 * kPi) / kPi, n_arc);
    if (s <= -half) {
      double t = std::atan2(z, s + half);
      if (t < 0) t += 2 * kPi;
      return n_arc + n_flat + in((t - 0.5 * kPi) / kPi, n_arc);
    }
    if (z >= 0) return n_arc + in((half - s) / (2 * half), n_flat);
    return 2 * n_arc + n_flat + in((s + half) / (2 * half), n_flat);
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
  BeadGrid(const std::vector<BeadFrame>& frames, std::span<const std::uint32_t> listed,
           double cell_mm)
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
  /// A thread's marks of the beads already listed.
  struct Seen {
    std::vector<std::uint32_t> stamp;
    std::uint32_t now = 0;
  };
  /// The beads sharing a cell with f, each once.
  void near(const BeadFrame& f, std::vector<std::uint32_t>& out, Seen& seen) const {
    if (begin_.empty()) return;
    std::vector<std::uint32_t> keys;
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
  /// cells, each piece's box grown by the reach; sorted and unique.
  void cells_of(const BeadFrame& f, std::vector<std::uint32_t>& keys) const {
    keys.clear();
    const int pieces = 1 + static_cast<int>(f.len / (2 * cell_));
    const double pad = f.reach() + kCoverMm;
    const auto c = [&](double x, int axis) {
      return std::clamp(static_cast<int>(std::floor((x - lo_[axis]) / cell_)), 0, n_[axis] - 1);
    };
    for (int i = 0; i < pieces; ++i) {
      const Vec3 p = f.a + (static_cast<double>(i) / pieces) * f.d;
      const Vec3 q = f.a + (static_cast<double>(i + 1) / pieces) * f.d;
      const Vec3 lo = p.cwiseMin(q) - Vec3::Constant(pad), hi = p.cwiseMax(q) + Vec3::Constant(pad);
      for (int x = c(lo.x(), 0); x <= c(hi.x(), 0); ++x)
        for (int y = c(lo.y(), 1); y <= c(hi.y(), 1); ++y)
          for (int z = c(lo.z(), 2); z <= c(hi.z(), 2); ++z)
            keys.push_back(static_cast<std::uint32_t>((x * n_[1] + y) * n_[2] + z));
    }
    if (pieces > 1) {
      std::sort(keys.begin(), keys.end());
      keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    }
  }
  double cell_;
  Vec3 lo_ = Vec3::Zero();
  std::array<int, 3> n_{};
  std::vector<std::uint32_t> begin_, beads_;
};

/// The points one bead lays, with the beads that touch it.
struct BeadPoints {
  std::vector<Vec3> p;
  std::vector<double> area;
  std::vector<std::uint32_t> group;  ///< local start of each group
  std::vector<std::uint32_t> touch;
  VoxelTag tag;
};

/// What the beads' sampling shares.
struct Sampler {
  std::span<const SurfaceBead> beads;
  const std::vector<BeadFrame>& frames;
  const BeadGrid& grid;
  std::span<const Vec3> face_points;
  double arc_step, along_step;

  /// Whether the outlines of bead k's centre line from `from` along `along` and of bead c
  /// may touch.
  [[nodiscard]] bool may_touch(const BeadFrame& f, const Vec3& from, const Vec3& along,
                               std::uint32_t c) const {
    const BeadFrame& g = frames[c];
    const double reach = f.reach() + g.reach() + kCoverMm;
    return segment_distance2(from, along, g.a, g.d) <= reach * reach;
  }
  /// The beads whose outline may touch bead k's, in index order.
  void touching(std::uint32_t k, std::vector<std::uint32_t>& touch, BeadGrid::Seen& seen) const {
    const BeadFrame& f = frames[k];
    touch.clear();
    grid.near(f, touch, seen);
    std::erase_if(touch, [&](std::uint32_t c) { return c == k || !may_touch(f, f.a, f.d, c); });
    std::sort(touch.begin(), touch.end());
  }

  void lay(std::uint32_t k, std::span<const std::uint32_t> faces, double ext_extra,
           BeadGrid::Seen& seen, BeadPoints& out) const;
};

void Sampler::lay(std::uint32_t k, std::span<const std::uint32_t> faces, double ext_extra,
                  BeadGrid::Seen& seen, BeadPoints& out) const {
  const BeadFrame& f = frames[k];
  const Section sec(f, arc_step, along_step);
  const int m = sec.cells();
  struct Cell {
    double s = 0, z = 0, len = 0;
  };
  std::vector<Cell> cell(static_cast<std::size_t>(m));
  for (int c = 0; c < m; ++c) {
    Cell& x = cell[static_cast<std::size_t>(c)];
    sec.cell(c, x.s, x.z, x.len);
  }
  const int rows = std::max(1, static_cast<int>(std::ceil(f.len / along_step)));
  const double du = f.len / rows;
  std::vector<std::uint8_t> marked(static_cast<std::size_t>(rows) * m, 0);
  for (const std::uint32_t i : faces) {
    const Vec3 rel = face_points[i] - f.a;
    const double u = rel.dot(f.dir);
    const int row = std::clamp(static_cast<int>(u / du), 0, rows - 1);
    marked[static_cast<std::size_t>(row) * m + sec.cell_of(rel.dot(f.across), rel.dot(f.up))] = 1;
  }
  touching(k, out.touch, seen);
  // Each touching bead: the span of k's centre line it may cover (length along it) and the
  // heights it may cover.
  struct Near {
    std::uint32_t bead;
    double u0, u1, z0, z1;
  };
  std::vector<Near> near;
  near.reserve(out.touch.size());
  for (const std::uint32_t c : out.touch) {
    const BeadFrame& g = frames[c];
    const double t0 = (g.a - f.a).dot(f.dir), t1 = (g.a + g.d - f.a).dot(f.dir);
    const double pad = f.reach() + g.reach() + kCoverMm, rz = g.r + kCoverMm;
    const double za = g.a.z(), zb = g.a.z() + g.d.z();
    near.push_back({c, std::min(t0, t1) - pad, std::max(t0, t1) + pad, std::min(za, zb) - rz,
                    std::max(za, zb) + rz});
  }
  // The outline extends past its faces by up to a quarter circle and a voxel.
  const double ext = 0.5 * kPi * f.r + ext_extra;
  std::vector<const Near*> active;
  std::vector<std::int8_t> covered(static_cast<std::size_t>(m));
  std::vector<std::uint8_t> exposed(static_cast<std::size_t>(m));
  for (int row = 0; row < rows; ++row) {
    const std::uint8_t* mk = &marked[static_cast<std::size_t>(row) * m];
    if (std::none_of(mk, mk + m, [](std::uint8_t x) { return x != 0; })) continue;
    const double u = (row + 0.5) * du;
    const Vec3 q0 = f.a + u * f.dir;
    active.clear();
    for (const Near& x : near)
      if (x.u0 <= u + 0.5 * du && x.u1 >= u - 0.5 * du) active.push_back(&x);
    std::fill(covered.begin(), covered.end(), -1);
    std::fill(exposed.begin(), exposed.end(), 0);
    const auto point = [&](int c) {
      const Cell& x = cell[static_cast<std::size_t>(c)];
      return Vec3(q0 + x.s * f.across + x.z * f.up);
    };
    const auto is_covered = [&](int c) {
      auto& memo = covered[static_cast<std::size_t>(c)];
      if (memo < 0) {
        const Vec3 p = point(c);
        memo = 0;
        Vec3 core;
        for (const Near* x : active) {
          if (p.z() < x->z0 || p.z() > x->z1) continue;
          if (detail::bead_closest(beads[x->bead], p, core) <= kCoverMm) {
            memo = 1;
            break;
          }
        }
      }
      return memo != 0;
    };
    for (int c = 0; c < m; ++c) {
      if (mk[c] == 0 || is_covered(c)) continue;
      exposed[static_cast<std::size_t>(c)] = 1;
      for (const int step : {1, m - 1}) {  // both ways round the outline
        double acc = 0;
        for (int j = (c + step) % m, n = 1; n < m && mk[j] == 0; j = (j + step) % m, ++n) {
          const double len = cell[static_cast<std::size_t>(j)].len;
          if (acc + len > ext + 1e-12 || is_covered(j)) break;
          acc += len;
          exposed[static_cast<std::size_t>(j)] = 1;
        }
      }
    }
    if (row % kRowsPerGroup == 0 || out.group.empty())
      out.group.push_back(static_cast<std::uint32_t>(out.p.size()));
    for (int c = 0; c < m; ++c) {
      if (exposed[static_cast<std::size_t>(c)] == 0) continue;
      out.p.push_back(point(c));
      out.area.push_back(cell[static_cast<std::size_t>(c)].len * du);
    }
  }
  if (!out.group.empty() && out.group.back() == out.p.size()) out.group.pop_back();
}

}  // namespace

void sample_bead_outlines(DepositSurface& s, std::span<const SurfaceBead> beads,
                          std::span<const Vec3> face_points,
                          std::span<const double> face_area_mm2) {
  const std::size_t n = s.faces.size();
  std::vector<BeadFrame> frames(beads.size());
  tbb::parallel_for(std::size_t{0}, beads.size(),
                    [&](std::size_t k) { frames[k] = BeadFrame::of(beads[k]); });
  // The faces on a bead's side (not past its ends) give way to the bead's outline.
  std::vector<std::uint8_t> replaced(n, 0);
  std::vector<std::uint32_t> begin(beads.size() + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t k = s.face_bead[i];
    if (k == kNoBead || !(frames[k].len > 0)) continue;
    const double u = (face_points[i] - frames[k].a).dot(frames[k].dir);
    if (!(u > 0 && u < frames[k].len)) continue;
    replaced[i] = 1;
    ++begin[k + 1];
  }
  for (std::size_t k = 0; k < beads.size(); ++k) begin[k + 1] += begin[k];
  std::vector<std::uint32_t> by_bead(begin.back());
  {
    std::vector<std::uint32_t> fill(begin.begin(), begin.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      if (replaced[i] != 0) by_bead[fill[s.face_bead[i]]++] = static_cast<std::uint32_t>(i);
  }
  std::vector<std::uint32_t> sampled;
  for (std::size_t k = 0; k < beads.size(); ++k)
    if (begin[k + 1] > begin[k]) sampled.push_back(static_cast<std::uint32_t>(k));
  const double v = s.voxel_mm;
  std::vector<BeadPoints> laid(sampled.size());
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
    const Sampler sampler{beads, frames, grid, face_points, v, 2 * v};
    tbb::enumerable_thread_specific<BeadGrid::Seen> seen_of([&] {
      BeadGrid::Seen seen;
      seen.stamp.assign(beads.size(), 0);
      return seen;
    });
    tbb::parallel_for(std::size_t{0}, sampled.size(), [&](std::size_t j) {
      const std::uint32_t k = sampled[j];
      const std::span<const std::uint32_t> faces(by_bead.data() + begin[k],
                                                 begin[k + 1] - begin[k]);
      sampler.lay(k, faces, v, seen_of.local(), laid[j]);
      // The bead's layer and feature from a face of its own line, if any.
      VoxelTag tag = s.face_tags[faces.front()];
      for (const std::uint32_t i : faces)
        if (s.face_tags[i].line == beads[k].line) {
          tag = s.face_tags[i];
          break;
        }
      tag.line = beads[k].line;
      laid[j].tag = tag;
    });
  }
  // The points: the faces kept, in their cell order (a cell's kept faces one group), then the
  // beads' in bead order.
  s.points_mm.clear();
  s.point_area_mm2.clear();
  s.point_tags.clear();
  s.point_groups.clear();
  for (std::size_t c = 0; c + 1 < s.face_cell_begin.size(); ++c) {
    bool first = true;
    for (std::uint32_t i = s.face_cell_begin[c]; i < s.face_cell_begin[c + 1]; ++i) {
      if (replaced[i] != 0) continue;
      if (first) s.point_groups.push_back(static_cast<std::uint32_t>(s.points_mm.size()));
      first = false;
      s.points_mm.push_back(face_points[i]);
      s.point_area_mm2.push_back(face_area_mm2[i]);
      s.point_tags.push_back(s.face_tags[i]);
    }
  }
  s.bead_touch_begin.assign(beads.size() + 1, 0);
  for (std::size_t j = 0; j < sampled.size(); ++j)
    s.bead_touch_begin[sampled[j] + 1] = static_cast<std::uint32_t>(laid[j].touch.size());
  for (std::size_t k = 0; k < beads.size(); ++k) s.bead_touch_begin[k + 1] += s.bead_touch_begin[k];
  s.bead_touch.clear();
  for (const BeadPoints& b : laid) {
    const auto base = static_cast<std::uint32_t>(s.points_mm.size());
    for (const std::uint32_t g : b.group) s.point_groups.push_back(base + g);
    s.points_mm.insert(s.points_mm.end(), b.p.begin(), b.p.end());
    s.point_area_mm2.insert(s.point_area_mm2.end(), b.area.begin(), b.area.end());
    s.point_tags.insert(s.point_tags.end(), b.p.size(), b.tag);
    s.bead_touch.insert(s.bead_touch.end(), b.touch.begin(), b.touch.end());
  }
  s.point_groups.push_back(static_cast<std::uint32_t>(s.points_mm.size()));
}

}  // namespace printtwin
