// The bead model: extruding moves -> voxels, height map, extrusion-into-air findings.
//
// Geometry of one bead (all in voxel units inside this file): the nozzle tip runs from A to
// B; the bead's top follows the tip, its height h is the gap to what lies beneath, its
// cross-section is a stadium of width w and height h (a (w-h) x h rectangle with half-discs
// of diameter h on its sides, area (w-h) h + pi h^2 / 4). Along the path the bead is cut by
// vertical planes: the mitre (bisector) plane at a joint with the previous/next move of the
// same continuous path, a plane square to the move at a path end or at a sharp turn. Mitred
// sweeps of a laterally symmetric section have exactly area x length volume and tile the
// path without gaps or double counting.
//
// Voxelisation: a voxel is occupied when its sample point lies inside the bead. The sample
// point is fixed per voxel (a hash of its key jitters it inside the voxel), so the expected
// voxel volume of any bead equals its exact volume whatever its width and orientation, and
// beads that touch share their boundary voxels without gaps or double counting. Voxels whose
// whole cell is inside are filled in runs without testing; only the boundary layer is tested.
#include "printtwin/deposit.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <thread>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/bits.hpp"
#include "core/zeroed_array.hpp"
#include "deposit/bead_raster.hpp"
#include "deposit/deposit_run.hpp"
#include "deposit/grid_writer.hpp"
#include "deposit/voxel_blocks.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

using detail::VoxelBlocks;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kJoinTolMm = 1e-3;        // path continuity: end of one move = start of next
constexpr double kMitreMinCos = -0.5;      // turns sharper than 120 deg get square cuts
constexpr std::size_t kHeightMapMax = 32767;  // rows of the height map (signed 16-bit max in raise_tops)
constexpr double kRegionGapMm = 1.0;         // unsupported stretches this close: one finding
constexpr std::size_t kMaxClustered = 4000;  // beyond this, one finding per layer and kind

/// Nominal layer height: the slicer's `;HEIGHT:` when given, else the Z step from the
/// previous layer's extrusions to this move. Sloped extrusions (vase-mode spirals, where
/// every move has its own Z) keep the nominal height of the last flat layer.
class LayerTracker {
 public:
  double nominal_mm(const Move& m, double nozzle_mm, double voxel_mm) {
    if (m.height_hint_mm > 0) return clamp(m.height_hint_mm, nozzle_mm, voxel_mm);
    const double z = m.end_mm.z();
    const bool sloped = std::abs(m.end_mm.z() - m.start_mm.z()) > 1e-6;
    if (sloped && have_nominal_) return nominal_;
    if (!have_layer_ || m.layer != layer_ || z > layer_z_ + 1e-6) {
      if (have_layer_ && z > layer_z_ + 1e-6) prev_z_ = layer_z_;
      have_layer_ = true;
      layer_ = m.layer;
      layer_z_ = z;
    }
    double h = z - prev_z_;
    if (!(h > 0.25 * voxel_mm)) h = 0.5 * nozzle_mm;
    nominal_ = clamp(h, nozzle_mm, voxel_mm);
    have_nominal_ = true;
    return nominal_;
  }

 private:
  static double clamp(double h, double nozzle_mm, double voxel_mm) {
    return std::clamp(h, std::min(voxel_mm, 0.5 * nozzle_mm), 2.0 * nozzle_mm);
  }
  bool have_layer_ = false;
  bool have_nominal_ = false;
  int layer_ = 0;
  double layer_z_ = 0;
  double prev_z_ = 0;
  double nominal_ = 0;
};

bool is_bead(const Move& m) { return m.kind == MoveKind::extrude && m.e_mm > 0; }

/// A constraint lo <= p*x + q*y + c <= hi on the (major x, minor y) plane.
struct Linear {
  double p = 0, q = 0, c = 0, inv_p = 0, inv_q = 0, lo = 0, hi = 0;
  bool flat = true;    // p == 0: independent of x
  bool flat_y = true;  // q == 0: independent of y
  void init(double p_, double q_, double c_, double lo_, double hi_) {
    p = p_, q = q_, c = c_, lo = lo_, hi = hi_;
    flat = std::abs(p) < 1e-12;
    inv_p = flat ? 0.0 : 1.0 / p;
    flat_y = std::abs(q) < 1e-12;
    inv_q = flat_y ? 0.0 : 1.0 / q;
  }
  /// Narrows [yl, yh] to the y where the constraint holds on the line x; false if empty.
  bool clip_y(double x, double& yl, double& yh) const { return narrow(p * x + c, inv_q, flat_y, yl, yh); }
  /// Narrows [xl, xh] to the x where the constraint holds on the line y; false if empty.
  bool clip(double y, double& xl, double& xh) const { return narrow(q * y + c, inv_p, flat, xl, xh); }

 private:
  /// lo <= k * t + rest <= hi narrows [tl, th] (inv_k = 1 / k; `flat`: k == 0).
  bool narrow(double rest, double inv_k, bool flat_k, double& tl, double& th) const {
    if (flat_k) return rest >= lo && rest <= hi;
    double t0 = (lo - rest) * inv_k;
    double t1 = (hi - rest) * inv_k;
    if (t0 > t1) std::swap(t0, t1);
    tl = std::max(tl, t0);
    th = std::min(th, t1);
    return tl <= th;
  }
};

/// The bead's footprint at one half-width, in the (major, minor) plane of the sweep: the
/// strip |n.(q-a)| <= hw between the start cut (m0.(q-a) >= 0) and the end cut (m1.(q-b) < 0).
struct Footprint {
  Linear side, start, end;
  // Every corner of the footprint is among these: the side lines' crossings with the cuts,
  // and the crossing of the two cuts when it lies between the sides (a short bead between
  // two sharp mitres is a triangle). Corners outside the footprint only widen the ranges.
  std::array<Vec2, 5> vertices;

  void init(const Vec2& a, const Vec2& b, const Vec2& d, const Vec2& n, const Vec2& m0,
            const Vec2& m1, double hw) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    side.init(n.x(), n.y(), -n.dot(a), -hw, hw);
    start.init(m0.x(), m0.y(), -m0.dot(a), 0.0, kInf);
    end.init(m1.x(), m1.y(), -m1.dot(b), -kInf, 0.0);
    // Intersections of the side lines s = +-hw with the two cut lines.
    const double k0 = m0.dot(n) / m0.dot(d);
    const double k1 = m1.dot(n) / m1.dot(d);
    vertices = {a + (-hw * k0) * d + hw * n, a + (hw * k0) * d - hw * n,
                b + (-hw * k1) * d + hw * n, b + (hw * k1) * d - hw * n, a};
    const double det = m0.x() * m1.y() - m0.y() * m1.x();
    if (std::abs(det) > 1e-12) {
      const double c0 = m0.dot(a), c1 = m1.dot(b);
      const Vec2 cross((c0 * m1.y() - m0.y() * c1) / det, (m0.x() * c1 - c0 * m1.x()) / det);
      if (std::abs(n.dot(cross - a)) <= hw) vertices[4] = cross;
    }
  }
  /// Interval of the major coordinate on the line minor = y.
  bool interval(double y, double& xl, double& xh) const {
    xl = -std::numeric_limits<double>::infinity();
    xh = std::numeric_limits<double>::infinity();
    return side.clip(y, xl, xh) && start.clip(y, xl, xh) && end.clip(y, xl, xh);
  }
  /// Interval of the minor coordinate on the line major = x.
  bool interval_y(double x, double& yl, double& yh) const {
    yl = -std::numeric_limits<double>::infinity();
    yh = std::numeric_limits<double>::infinity();
    return side.clip_y(x, yl, yh) && start.clip_y(x, yl, yh) && end.clip_y(x, yl, yh);
  }
  /// Range of the minor coordinate over the band of lines major in [x0, x1]; false if empty.
  bool minor_range_over(double x0, double x1, double& lo, double& hi) const {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (const double x : {x0, x1}) {
      double a, b;
      if (interval_y(x, a, b)) lo = std::min(lo, a), hi = std::max(hi, b);
    }
    for (const auto& v : vertices)
      if (v.x() >= x0 && v.x() <= x1) lo = std::min(lo, v.y()), hi = std::max(hi, v.y());
    return lo <= hi;
  }
  void minor_range(double& lo, double& hi) const {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (const auto& v : vertices) {
      lo = std::min(lo, v.y());
      hi = std::max(hi, v.y());
    }
  }
};

struct PendingBead {
  Move move;
  double nominal_h_mm = 0;
  bool continues_path = false;  // joined to the previous bead
  Vec2 m0 = Vec2::Zero();       // cut normal at the start (xy, unit)
};

struct OpenStretch {
  UnsupportedStretch s;
  bool active = false;
};

}  // namespace

double stadium_width_mm(double area_mm2, double height_mm) {
  if (!(height_mm > 0)) return 0;
  return area_mm2 / height_mm + (1.0 - kPi / 4.0) * height_mm;
}

// ---------------------------------------------------------------------------------------
struct DepositBuilder::State {
  detail::DepositRunSettings settings;
  double voxel = 0.05;
  double inv_voxel = 20;
  double filament_area_mm2 = 0;
  double nozzle_mm = 0.4;
  VoxelGrid grid;
  // Height map, per column: rows occupied up to (0 = bed/empty). Stored in 8 x 8 tiles in the
  // blocks' order (top_index), so a tile of the sweep and the samples across a bead touch a
  // cache line or two instead of one page per row.
  ZeroedArray<std::uint16_t> top;
  // Per column (same layout as `top`): the layer of the move that last wrote the column's top
  // voxel, so the sweep never reads the grid (whose writes may still be under way).
  ZeroedArray<std::int32_t> top_layer;
  int nx = 0, ny = 0, nz = 0;
  std::size_t tiles_x = 0;  // tiles (blocks) per row of the height map
  double ox_ = 0, oy_ = 0, oz_ = 0;  // grid origin (mm)
  LayerTracker layers;
  std::optional<PendingBead> pending;
  std::vector<double> gaps_;  // scratch
  std::vector<std::int32_t> reached_;  // scratch: the voxel layers a bead reaches
  std::vector<std::uint64_t> masks_;   // scratch: a tile's occupancy word per reached layer
  std::vector<double> offsets_;  // scratch: across-bead sample offsets (mm)

  // Support tracking along the current continuous path.
  bool path_has_support = false;
  OpenStretch stretch;
  std::vector<UnsupportedStretch> all_stretches;
  double unsupported_mm = 0;

  double extruded_mm3 = 0;
  std::size_t overlap_voxels = 0;
  std::size_t beads = 0;
  std::size_t skipped = 0;

  // The grid's writes, in order, on a writer thread when there is a second core.
  detail::GridWriter writer;

  State(const detail::DepositRunSettings& s, const PrinterProfile& p, const Vec3& origin,
        const Eigen::Vector3i& dims)
      : settings(s),
        voxel(s.voxel_mm),
        inv_voxel(1.0 / s.voxel_mm),
        filament_area_mm2(p.filament_area_mm2()),
        nozzle_mm(p.nozzle_diameter_mm),
        grid(s.voxel_mm, origin, dims),
        nx(dims.x()),
        ny(dims.y()),
        nz(dims.z()),
        ox_(origin.x()),
        oy_(origin.y()),
        oz_(origin.z()),
        writer(grid, s.writer_thread && std::thread::hardware_concurrency() > 1) {
    tiles_x = static_cast<std::size_t>(VoxelBlocks::block_dims(grid).x());
    top = ZeroedArray<std::uint16_t>(tiles_x * static_cast<std::size_t>(VoxelBlocks::block_dims(grid).y()) * 64 + 1);  // + padding (count_held)
    top_layer = ZeroedArray<std::int32_t>(top.size());
  }

  // -- columns ---------------------------------------------------------------------------
  /// floor(v) for finite v in int range (std::floor is a library call on baseline x86-64).
  static int floor_int(double v) {
    const int i = static_cast<int>(v);
    return i - (v < static_cast<double>(i) ? 1 : 0);
  }
  /// Deposit rows in the column under (x, y) (mm), 0 outside the grid.
  [[nodiscard]] int top_rows(double x_mm, double y_mm) const {
    return top_rows_at((x_mm - ox_) * inv_voxel, (y_mm - oy_) * inv_voxel);
  }
  /// Same at (u, v) in voxel units from the grid origin.
  [[nodiscard]] int top_rows_at(double u, double v) const { return height_map().rows_at(u, v); }
  [[nodiscard]] detail::HeightMapView height_map() const { return {top.data(), tiles_x, nx, ny}; }
  /// Index into `top` of column (i, j) (in the grid).
  [[nodiscard]] std::size_t top_index(int i, int j) const { return height_map().index(i, j); }
  /// Height (mm, machine frame) of the deposit top in the column under p, or the grid
  /// bottom (the bed) outside the grid.
  [[nodiscard]] double top_mm(double x_mm, double y_mm) const { return oz_ + top_rows(x_mm, y_mm) * voxel; }
  /// Layer of the move that last wrote the top voxel of the column under (x, y) (mm);
  /// nullopt when the column is empty or outside the grid.
  [[nodiscard]] std::optional<std::int32_t> top_layer_at(double x_mm, double y_mm) const {
    const double u = (x_mm - ox_) * inv_voxel, v = (y_mm - oy_) * inv_voxel;
    const int i = floor_int(u), j = floor_int(v);
    if (i < 0 || j < 0 || i >= nx || j >= ny) return std::nullopt;
    const std::size_t at = top_index(i, j);
    if (top[at] == 0) return std::nullopt;
    return top_layer[at];
  }
  /// Smallest row count r with oz + r * voxel >= z_mm (the same comparison top_mm makes).
  [[nodiscard]] int rows_reaching(double z_mm) const {
    int r = static_cast<int>(std::ceil((z_mm - oz_) * inv_voxel));
    while (r > 0 && oz_ + (r - 1) * voxel >= z_mm) --r;
    while (!(oz_ + r * voxel >= z_mm)) ++r;
    return std::max(r, 0);
  }

  /// Claims (ZeroedArray::claim) the height map's pages under the box of segment a-b widened
  /// by `margin_mm`: the bead reads these columns before it raises them, and the first layer
  /// reads columns nobody has written yet.
  void claim_columns(const Vec3& a, const Vec3& b, double margin_mm) {
    const int i0 = std::max(0, floor_int((std::min(a.x(), b.x()) - margin_mm - ox_) * inv_voxel));
    const int i1 = std::min(nx - 1, floor_int((std::max(a.x(), b.x()) + margin_mm - ox_) * inv_voxel));
    const int j0 = std::max(0, floor_int((std::min(a.y(), b.y()) - margin_mm - oy_) * inv_voxel));
    const int j1 = std::min(ny - 1, floor_int((std::max(a.y(), b.y()) + margin_mm - oy_) * inv_voxel));
    if (i0 > i1 || j0 > j1) return;
    for (int j = j0 & ~7; j <= j1; j += 8) {
      const std::size_t first = top_index(i0, j), last = top_index(i1, j) + 63;
      top.claim_range(first, last);
      top_layer.claim_range(first, last);
    }
  }

  // -- moves -----------------------------------------------------------------------------
  void add(const Move& m) {
    if (!is_bead(m)) {
      flush(std::nullopt);
      return;
    }
    extruded_mm3 += m.e_mm * filament_area_mm2;
    if (m.xy_length_mm() < 1e-9) {  // Z-only or in-place extrusion: a blob we do not model
      ++skipped;
      flush(std::nullopt);
      return;
    }
    const Vec2 d = (m.end_mm - m.start_mm).head<2>().normalized();
    bool continues = false;
    bool mitred = false;
    Vec2 m0 = d;
    if (pending) {
      const Move& p = pending->move;
      continues = p.layer == m.layer && (p.end_mm - m.start_mm).norm() < kJoinTolMm;
      if (continues) {
        const Vec2 dp = (p.end_mm - p.start_mm).head<2>().normalized();
        if (dp.dot(d) >= kMitreMinCos) {
          m0 = (dp + d).normalized();
          mitred = true;
        }
      }
      // The previous bead ends on the shared mitre plane, or square when not mitred.
      flush(mitred ? std::optional<Vec2>(m0) : std::nullopt);
    }
    PendingBead pb;
    pb.move = m;
    pb.nominal_h_mm = layers.nominal_mm(m, nozzle_mm, voxel);
    pb.continues_path = continues;
    pb.m0 = m0;
    writer.tag(VoxelTag{static_cast<std::uint32_t>(std::max(m.line, 0L)), m.layer, m.feature});
    pending = pb;
  }

  /// Lays the pending bead; `m1` is its end cut normal (nullopt: square cut).
  void flush(std::optional<Vec2> m1) {
    if (!pending) return;
    const PendingBead pb = *pending;
    pending.reset();
    const Vec2 d = (pb.move.end_mm - pb.move.start_mm).head<2>().normalized();
    lay(pb, m1.value_or(d));
  }

  void close_stretch(bool end_supported) {
    if (!stretch.active) return;
    stretch.active = false;
    stretch.s.bridge = stretch.s.bridge && end_supported;
    unsupported_mm += stretch.s.length_mm;
    if (stretch.s.length_mm >= settings.min_unsupported_mm) all_stretches.push_back(stretch.s);
  }

  void lay(const PendingBead& pb, const Vec2& m1) {
    const Move& mv = pb.move;
    const double len_mm = mv.xy_length_mm();
    const double volume_mm3 = mv.e_mm * filament_area_mm2;
    const double area_mm2 = volume_mm3 / len_mm;
    const Vec3 a = mv.start_mm;
    const Vec3 b = mv.end_mm;
    const Vec2 d = (b - a).head<2>() / len_mm;
    const Vec2 n(-d.y(), d.x());
    const int samples = std::max(1, static_cast<int>(std::ceil(len_mm * inv_voxel)));
    claim_columns(a, b, 2 * nozzle_mm);

    // Height: the gap between the tip and the surface beneath the centre line. A column whose
    // top is within half a layer of the tip holds this layer's neighbours (or a partly
    // covered corner) and says nothing about what is beneath, unless its top voxel was laid
    // by an earlier layer (the first turn of a vase-mode spiral); gaps over 1.5 layers are
    // air. The median of the remaining gaps is the bead height (the nominal layer height when
    // none remain, or when they agree with it to within the voxel quantisation).
    const double nominal = pb.nominal_h_mm;
    gaps_.clear();
    for (int i = 0; i < samples; ++i) {
      const Vec3 q = a + ((i + 0.5) / samples) * (b - a);
      const double t = top_mm(q.x(), q.y());
      const double gap = q.z() - t;
      if (gap > 1.5 * nominal + 0.5 * voxel || gap < 0.5 * voxel) continue;
      if (gap < 0.5 * nominal) {  // the layer that laid the column's top voxel
        const auto top_of = top_layer_at(q.x(), q.y());
        if (!top_of || *top_of >= mv.layer) continue;
      }
      gaps_.push_back(gap);
    }
    double h = nominal;
    if (!gaps_.empty()) {
      auto mid = gaps_.begin() + static_cast<std::ptrdiff_t>(gaps_.size() / 2);
      std::nth_element(gaps_.begin(), mid, gaps_.end());
      if (std::abs(*mid - nominal) > voxel + 1e-9) h = *mid;
    }
    double w = stadium_width_mm(area_mm2, h);
    if (w < h) {  // too little material for a full-height bead: a round strand
      h = std::sqrt(4.0 * area_mm2 / kPi);
      w = h;
    }

    // Support: fraction of the bead's width resting on bed or deposit, per sample.
    if (!pb.continues_path) {
      close_stretch(false);
      path_has_support = false;
    }
    const int across = std::max(3, static_cast<int>(std::ceil(w * inv_voxel)));
    const double tol = 0.5 * h;
    const double step_mm = len_mm / samples;
    offsets_.resize(static_cast<std::size_t>(across));
    for (int j = 0; j < across; ++j) offsets_[static_cast<std::size_t>(j)] = -0.5 * w + (j + 0.5) * w / across;
    // The samples across, in voxel units relative to the grid origin.
    for (double& s : offsets_) s *= inv_voxel;
    const detail::HeightMapView map = height_map();
    const double nxv = n.x(), nyv = n.y();
    // A level bead's samples all have the start's height (a + t * 0 is a), so the rows they
    // need are found once.
    const bool level = a.z() == b.z();
    const int level_rows = level ? rows_reaching((a.z() - h) - tol) : 0;
    for (int i = 0; i < samples; ++i) {
      const Vec3 q = a + ((i + 0.5) / samples) * (b - a);
      const double bottom = q.z() - h;
      const int need_rows = level ? level_rows : rows_reaching(bottom - tol);
      const double qx = (q.x() - ox_) * inv_voxel, qy = (q.y() - oy_) * inv_voxel;
      const int held = detail::count_held(map, qx, qy, nxv, nyv, offsets_.data(), across, need_rows);
      const bool supported = held >= settings.support_fraction * across - 1e-9;
      if (supported) {
        close_stretch(true);
        path_has_support = true;
      } else {
        if (!stretch.active) {
          stretch.active = true;
          stretch.s = UnsupportedStretch{};
          stretch.s.layer = mv.layer;
          stretch.s.first_line = mv.line;
          stretch.s.start_mm = a + (static_cast<double>(i) / samples) * (b - a);
          stretch.s.bridge = path_has_support;
          stretch.s.feature = mv.feature;
        }
        stretch.s.last_line = mv.line;
        stretch.s.end_mm = a + ((i + 1.0) / samples) * (b - a);
        stretch.s.length_mm += step_mm;
      }
    }

    sweep(pb, a, b, d, n, m1, h, w);
    ++beads;
  }

  // -- voxelisation ----------------------------------------------------------------------
  /// Raises the 64 columns of a height-map tile to at least `rows` where `mask` (bit
  /// y * 8 + x) is set; where the write reaches the column's top (rows >= its height), the
  /// column's top voxel is now this move's: its layer goes into `layers` (same layout).
  static void raise_tops(std::uint16_t* tile, std::int32_t* layers, std::uint64_t mask, std::uint16_t rows,
                         std::int32_t layer) {
#if defined(__SSE2__)
    const __m128i bit = _mm_setr_epi16(1, 2, 4, 8, 16, 32, 64, 128);
    const __m128i value = _mm_set1_epi16(static_cast<short>(rows));
    const __m128i layer4 = _mm_set1_epi32(layer);
    for (int y = 0; y < 8; ++y, tile += 8, layers += 8) {
      const auto m = static_cast<short>((mask >> (8 * y)) & 0xFFu);
      if (m == 0) continue;
      const __m128i lanes = _mm_cmpeq_epi16(_mm_and_si128(_mm_set1_epi16(m), bit), bit);
      auto* p = reinterpret_cast<__m128i*>(tile);
      const __m128i old = _mm_loadu_si128(p);
      // Heights stay below 32768 rows (kHeightMapMax), so the signed compare and max are exact.
      const __m128i reach = _mm_andnot_si128(_mm_cmpgt_epi16(old, value), lanes);
      _mm_storeu_si128(p, _mm_max_epi16(old, _mm_and_si128(lanes, value)));
      auto* lp = reinterpret_cast<__m128i*>(layers);
      const __m128i r_lo = _mm_unpacklo_epi16(reach, reach), r_hi = _mm_unpackhi_epi16(reach, reach);
      _mm_storeu_si128(lp, _mm_or_si128(_mm_and_si128(r_lo, layer4), _mm_andnot_si128(r_lo, _mm_loadu_si128(lp))));
      _mm_storeu_si128(lp + 1,
                       _mm_or_si128(_mm_and_si128(r_hi, layer4), _mm_andnot_si128(r_hi, _mm_loadu_si128(lp + 1))));
    }
#else
    for (int y = 0; y < 8; ++y, tile += 8, layers += 8) {
      const auto m = static_cast<unsigned>(mask >> (8 * y)) & 0xFFu;
      for (int x = 0; x < 8; ++x) {
        if (((m >> x) & 1u) == 0) continue;
        if (rows >= tile[x]) layers[x] = layer;
        tile[x] = std::max(tile[x], rows);
      }
    }
#endif
  }

  void sweep(const PendingBead& pb, const Vec3& a_mm, const Vec3& b_mm, const Vec2& d,
             const Vec2& n, const Vec2& m1, double h_mm, double w_mm) {
    // Heights that are whole voxels up to rounding (Z 0.4 / 0.05 = 7.9999999) are snapped, so
    // layer boundaries stay on voxel boundaries.
    auto snap = [](double v) {
      const double r = std::round(v);
      return std::abs(v - r) < 1e-6 ? r : v;
    };
    const Vec3 o = grid.origin_mm();
    Vec3 a = (a_mm - o) * inv_voxel;
    Vec3 b = (b_mm - o) * inv_voxel;
    a.z() = snap(a.z());
    b.z() = snap(b.z());
    const double len = (b - a).head<2>().norm();
    const double hh = snap(h_mm * inv_voxel);
    const double r = 0.5 * hh;
    const double r2 = r * r;
    const double flat = 0.5 * (w_mm - h_mm) * inv_voxel;
    const double slope = (b.z() - a.z()) / len;
    const double zt_lo = std::min(a.z(), b.z());
    const double zt_hi = std::max(a.z(), b.z());
    const double zc_lo = zt_lo - r;
    const double zc_hi = zt_hi - r;
    const Vec2 a2 = a.head<2>(), b2 = b.head<2>();

    // The frame of the sample-point tests: relative to the voxel holding the start.
    detail::BeadFrame f;
    f.ia = floor_int(a.x());
    f.ja = floor_int(a.y());
    f.ka = floor_int(a.z());
    f.fa_x = static_cast<float>(a.x() - f.ia);
    f.fa_y = static_cast<float>(a.y() - f.ja);
    f.d_x = static_cast<float>(d.x()), f.d_y = static_cast<float>(d.y());
    f.n_x = static_cast<float>(n.x()), f.n_y = static_cast<float>(n.y());
    f.m0_x = static_cast<float>(pb.m0.x()), f.m0_y = static_cast<float>(pb.m0.y());
    f.m1_x = static_cast<float>(m1.x()), f.m1_y = static_cast<float>(m1.y());
    f.e1 = static_cast<float>(m1.dot(b2 - a2));
    f.c0 = static_cast<float>(a.z() - r - f.ka);
    f.slope = static_cast<float>(slope);
    f.r = static_cast<float>(r), f.r2 = static_cast<float>(r2), f.flat = static_cast<float>(flat);

    // Tiles: the 8 x 8 cells of a block's z-slice. The bead's footprint at its widest over
    // its voxel layers (widened by kBoundSlack so that the bounds never cut a cell the
    // single-precision test would take) gives the block rows it reaches, the blocks of each
    // row and the rows of each block, once per bead; each such tile's 64 sample points are
    // then tested layer by layer and written as one occupancy word per layer. (Bounds per
    // layer would be tighter at the rounded top and bottom, but computing them cost more than
    // the few extra tile tests they save.) The tiles of one bead are disjoint and carry one
    // tag, so the order they are written in changes nothing.
    constexpr double kBoundSlack = 1e-3;
    const auto& bdims = VoxelBlocks::block_dims(grid);
    const std::int32_t layer = pb.move.layer;
    const int k_lo = std::max(0, static_cast<int>(std::floor(zt_lo - hh)));
    const int k_hi = std::min(nz - 1, static_cast<int>(std::ceil(zt_hi)) - 1);
    // The layers the section reaches, and its widest half-width over them.
    reached_.clear();
    double hw = -1;
    for (int k = k_lo; k <= k_hi; ++k) {
      // Range of the height offset from the section's centre over this layer of voxels.
      const double dz_lo = std::max(k - zc_hi, -r);
      const double dz_hi = std::min(k + 1.0 - zc_lo, r);
      if (dz_lo >= dz_hi) continue;
      reached_.push_back(k);
      const double dz0 = std::clamp(0.0, dz_lo, dz_hi);
      hw = std::max(hw, flat + std::sqrt(std::max(0.0, r2 - dz0 * dz0)) + kBoundSlack);
    }
    if (reached_.empty()) return;
    masks_.resize(reached_.size());
    Footprint outer;
    outer.init(a2, b2, d, n, pb.m0, m1, hw);
    double ylo, yhi;
    outer.minor_range(ylo, yhi);
    const bool exhaustive = settings.exhaustive_tiles;
    const double box_lo_x = std::min(a2.x(), b2.x()) - 2 * hw - 2, box_hi_x = std::max(a2.x(), b2.x()) + 2 * hw + 2;
    if (exhaustive) ylo = std::min(a2.y(), b2.y()) - 2 * hw - 2, yhi = std::max(a2.y(), b2.y()) + 2 * hw + 2;
    const int j_lo = std::max(0, floor_int(std::clamp(ylo - kBoundSlack, -2.0, ny + 1.0)));
    const int j_hi = std::min(ny - 1, floor_int(std::clamp(yhi + kBoundSlack, -2.0, ny + 1.0)));
    for (int by = j_lo >> 3; by <= j_hi >> 3; ++by) {
      const int row_lo = std::max(j_lo - 8 * by, 0);
      const int row_hi = std::min(j_hi - 8 * by + 1, 8);
      // x-range of the footprint over the band of sample lines y in [y0, y1].
      const double y0 = 8.0 * by + row_lo, y1 = 8.0 * by + row_hi;
      double xl = std::numeric_limits<double>::infinity(), xh = -xl;
      for (const double y : {y0, y1}) {
        double lo, hi;
        if (outer.interval(y, lo, hi)) xl = std::min(xl, lo), xh = std::max(xh, hi);
      }
      for (const auto& v : outer.vertices)
        if (v.y() >= y0 && v.y() <= y1) xl = std::min(xl, v.x()), xh = std::max(xh, v.x());
      if (exhaustive) xl = box_lo_x, xh = box_hi_x;
      if (!(xl <= xh)) continue;
      const int i_lo = std::max(0, floor_int(std::clamp(xl - kBoundSlack, -2.0, nx + 1.0)));
      const int i_hi = std::min(nx - 1, floor_int(std::clamp(xh + kBoundSlack, -2.0, nx + 1.0)));
      const bool one_tile = (i_lo >> 3) == (i_hi >> 3);
      for (int bx = i_lo >> 3; bx <= i_hi >> 3 && bx < bdims.x(); ++bx) {
        const int x_end = std::min(8, nx - 8 * bx);  // cells of this block inside the grid
        const unsigned lanes = (1u << x_end) - 1u;
        // Rows of this tile the footprint reaches (over its sample columns x in [8 bx, 8 bx + 8]).
        int t_lo = row_lo, t_hi = row_hi;
        if (!one_tile && !exhaustive) {
          double tyl, tyh;
          if (!outer.minor_range_over(8.0 * bx, 8.0 * bx + 8.0, tyl, tyh)) continue;
          t_lo = std::max(row_lo, floor_int(std::clamp(tyl - kBoundSlack - 8.0 * by, -1.0, 9.0)));
          t_hi = std::min(row_hi, floor_int(std::clamp(tyh + kBoundSlack - 8.0 * by, -1.0, 9.0)) + 1);
          if (t_lo >= t_hi) continue;
        }
        const std::size_t at = top_index(8 * bx, 8 * by);
        detail::test_tile_layers(f, 8 * bx, 8 * by, reached_.data(), static_cast<int>(reached_.size()), t_lo, t_hi,
                                 lanes, masks_.data());
        for (std::size_t layer_at = 0; layer_at < reached_.size(); ++layer_at) {
          const std::uint64_t mask = masks_[layer_at];
          if (mask == 0) continue;
          const int k = reached_[layer_at];
          writer.tile(bx, by, k, mask);
          raise_tops(top.data() + at, top_layer.data() + at, mask, static_cast<std::uint16_t>(k + 1), layer);
        }
      }
    }
  }

  // -- results ---------------------------------------------------------------------------
  DepositResult finish() {
    flush(std::nullopt);
    close_stretch(false);
    overlap_voxels = writer.finish();  // every write in the grid from here on
    DepositResult r;
    r.voxel_mm = voxel;
    r.voxels = grid.count();
    r.volume_mm3 = static_cast<double>(r.voxels) * voxel * voxel * voxel;
    r.extruded_mm3 = extruded_mm3;
    r.overlap_mm3 = static_cast<double>(overlap_voxels) * voxel * voxel * voxel;
    r.beads = beads;
    r.skipped_moves = skipped;
    r.unsupported_mm = unsupported_mm;
    r.bbox_mm = occupied_bbox();
    r.unsupported = std::move(all_stretches);
    r.findings = make_findings(r.unsupported);
    r.memory_bytes = grid.memory_bytes() + top.size() * sizeof(std::uint16_t) +
                     top_layer.size() * sizeof(std::int32_t);
    top = {};
    top_layer = {};
    r.grid = std::move(grid);
    return r;
  }

  [[nodiscard]] Box3 occupied_bbox() const {
    Eigen::Vector3i lo = Eigen::Vector3i::Constant(std::numeric_limits<int>::max());
    Eigen::Vector3i hi = Eigen::Vector3i::Constant(std::numeric_limits<int>::min());
    // Min and max do not depend on the order: the allocated blocks as they come, not the
    // whole directory (most of which, over the bed around the part, was never touched).
    VoxelBlocks::visit_blocks_as_allocated(grid, [&](const VoxelBlocks::BlockView& blk) {
      std::uint64_t any = 0;
      for (int z = 0; z < 8; ++z) {
        if (blk.occupancy[z] == 0) continue;
        any |= blk.occupancy[z];
        lo.z() = std::min(lo.z(), blk.base.z + z);
        hi.z() = std::max(hi.z(), blk.base.z + z);
      }
      if (any == 0) return;
      std::uint32_t xs = 0, ys = 0;
      for (int y = 0; y < 8; ++y) {
        const auto row = static_cast<std::uint32_t>((any >> (8 * y)) & 0xFF);
        xs |= row;
        if (row) ys |= 1u << y;
      }
      lo.x() = std::min(lo.x(), blk.base.x + std::countr_zero(xs));
      hi.x() = std::max(hi.x(), blk.base.x + 31 - std::countl_zero(xs));
      lo.y() = std::min(lo.y(), blk.base.y + std::countr_zero(ys));
      hi.y() = std::max(hi.y(), blk.base.y + 31 - std::countl_zero(ys));
    });
    Box3 box;
    if (lo.x() > hi.x()) return box;
    box.min = grid.origin_mm() + voxel * lo.cast<double>();
    box.max = grid.origin_mm() + voxel * (hi.cast<double>() + Eigen::Vector3d::Ones());
    return box;
  }

  static std::vector<Finding> make_findings(const std::vector<UnsupportedStretch>& stretches) {
    // One finding per region: stretches of the same layer and kind whose boxes come within
    // kRegionGapMm of each other (one overhang, one bridged span) are merged.
    struct Group {
      int layer;
      bool bridge;
      Box3 box;
      std::vector<const UnsupportedStretch*> items;
    };
    auto box_of = [](const UnsupportedStretch& s) {
      Box3 b;
      b.extend(s.start_mm);
      b.extend(s.end_mm);
      return b;
    };
    auto near = [](const Box3& a, const Box3& b) {
      return (a.min.array() - kRegionGapMm <= b.max.array()).all() &&
             (b.min.array() - kRegionGapMm <= a.max.array()).all();
    };
    std::vector<Group> groups;
    std::size_t layer_begin = 0;  // first group of the current (layer, kind) run
    for (const auto& s : stretches) {
      const Box3 b = box_of(s);
      Group* target = nullptr;
      const std::size_t n = groups.size();
      for (std::size_t g = layer_begin; g < n; ++g) {
        if (groups[g].layer != s.layer || groups[g].bridge != s.bridge) continue;
        if (n - layer_begin > kMaxClustered || near(groups[g].box, b)) {
          target = &groups[g];
          break;
        }
      }
      if (target == nullptr) {
        if (!groups.empty() && groups.back().layer != s.layer) layer_begin = groups.size();
        groups.push_back(Group{s.layer, s.bridge, Box3{}, {}});
        target = &groups.back();
      }
      target->box.extend(b);
      target->items.push_back(&s);
    }
    // Merging may have made groups of one layer touch: merge until stable.
    for (bool merged = true; merged;) {
      merged = false;
      for (std::size_t i = 0; i < groups.size() && !merged; ++i)
        for (std::size_t j = i + 1; j < groups.size() && groups[j].layer == groups[i].layer; ++j)
          if (groups[j].bridge == groups[i].bridge &&
              near(groups[i].box, groups[j].box)) {
            groups[i].box.extend(groups[j].box);
            groups[i].items.insert(groups[i].items.end(), groups[j].items.begin(), groups[j].items.end());
            groups.erase(groups.begin() + static_cast<std::ptrdiff_t>(j));
            merged = true;
            break;
          }
    }
    std::stable_sort(groups.begin(), groups.end(), [](const Group& x, const Group& y) {
      if (x.layer != y.layer) return x.layer < y.layer;
      if (x.bridge != y.bridge) return x.bridge < y.bridge;
      return x.items.front()->first_line < y.items.front()->first_line;
    });
    std::vector<Finding> out;
    for (const auto& g : groups) {
      double total = 0;
      const UnsupportedStretch* longest = g.items.front();
      Box3 extent;
      for (const auto* s : g.items) {
        total += s->length_mm;
        if (s->length_mm > longest->length_mm) longest = s;
        extent.extend(s->start_mm);
        extent.extend(s->end_mm);
      }
      Finding f;
      f.severity = g.bridge ? Severity::info : Severity::warning;
      f.code = g.bridge ? "extrusion_into_air_bridge" : "extrusion_into_air_cantilever";
      const std::string kind = g.bridge ? "bridged (supported at both ends)" : "cantilevered (droops)";
      f.message = "layer " + std::to_string(g.layer) + ": " + std::to_string(g.items.size()) +
                  " unsupported " + kind + " stretch" + (g.items.size() == 1 ? "" : "es") + ", " +
                  format_fixed(total, 1) + " mm in total; longest " +
                  format_fixed(longest->length_mm, 1) + " mm at G-code lines " +
                  std::to_string(longest->first_line) + "-" + std::to_string(longest->last_line) +
                  " (" + std::string(to_string(longest->feature)) + ")";
      f.position_mm = longest->start_mm;
      f.extent_mm = extent;
      f.line = longest->first_line;
      f.layer = g.layer;
      f.value = total;
      f.count = static_cast<long>(g.items.size());
      out.push_back(std::move(f));
    }
    return out;
  }
};

// ---------------------------------------------------------------------------------------
namespace {

Status check_settings(const DepositSettings& s) {
  if (!(s.voxel_mm >= 0.001 && s.voxel_mm <= 10.0))
    return usage_error("voxel size must be between 0.001 and 10 mm, got " + format_number(s.voxel_mm));
  if (!(s.support_fraction >= 0.0 && s.support_fraction <= 1.0))
    return usage_error("support fraction must be between 0 and 1, got " +
                       format_number(s.support_fraction));
  return Ok{};
}

struct Frame {
  Vec3 origin = Vec3::Zero();
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();
};

Frame frame_for(const Box3& tips, double margin_mm, double voxel) {
  Frame f;
  if (tips.empty()) {
    f.dims = Eigen::Vector3i::Ones();
    return f;
  }
  // Origin on a multiple of the voxel in X/Y; Z starts at the bed (z = 0) so that layer
  // boundaries fall on voxel boundaries when the layer height is a multiple of the voxel.
  const double x0 = std::floor((tips.min.x() - margin_mm) / voxel) * voxel;
  const double y0 = std::floor((tips.min.y() - margin_mm) / voxel) * voxel;
  const double z0 = std::min(0.0, std::floor(tips.min.z() / voxel) * voxel);
  f.origin = Vec3(x0, y0, z0);
  const Vec3 span = (tips.max + Vec3(margin_mm, margin_mm, voxel)) - f.origin;
  f.dims = (span / voxel).array().ceil().cast<int>().max(1).matrix();
  return f;
}

double grid_bytes(const Eigen::Vector3i& dims, std::size_t blocks, std::size_t tags) {
  const Eigen::Vector3d bd = ((dims.array() + 7) / 8).cast<double>();
  return bd.prod() * 4.0 + static_cast<double>(blocks) * VoxelBlocks::kBlockBytes +
         static_cast<double>(dims.x()) * dims.y() * (sizeof(std::uint16_t) + sizeof(std::int32_t)) +  // height, top layer
         static_cast<double>(tags) * sizeof(VoxelTag) +
         1024.0 * VoxelBlocks::kBlockBytes;
}

/// The estimate at one voxel size: bead footprints marked block by block.
DepositEstimate estimate_at(std::span<const Move> moves, const PrinterProfile& profile, double voxel) {
  DepositEstimate e;
  const double fa = profile.filament_area_mm2();
  const double nozzle = profile.nozzle_diameter_mm;
  Box3 tips;
  double margin = 0;
  std::size_t tags = 0;
  {
    LayerTracker layers;
    for (const auto& m : moves) {
      if (!is_bead(m)) continue;
      e.extruded_mm3 += m.e_mm * fa;
      tips.extend(m.start_mm);
      tips.extend(m.end_mm);
      ++tags;
      const double len = m.xy_length_mm();
      if (len < 1e-9) continue;
      const double h = layers.nominal_mm(m, nozzle, voxel);
      margin = std::max(margin, 0.5 * stadium_width_mm(m.e_mm * fa / len, h));
    }
  }
  margin = std::min(margin, 5.0 * nozzle) + 2 * voxel;
  const Frame f = frame_for(tips, margin, voxel);
  e.origin_mm = f.origin;
  e.dims = f.dims;
  const Eigen::Vector3i bd = (f.dims.array() + 7) / 8;
  const double dir_entries = static_cast<double>(bd.x()) * bd.y() * bd.z();
  if (dir_entries > 4.0e9) {  // a bitmap this large is pointless: report the directory alone
    e.bytes = static_cast<std::size_t>(std::min(dir_entries * 4.0, 1.0e18));
    return e;
  }
  std::vector<std::uint64_t> marked((static_cast<std::size_t>(dir_entries) + 63) / 64, 0);
  const double block_mm = 8 * voxel;
  LayerTracker layers;
  for (const auto& m : moves) {
    if (!is_bead(m)) continue;
    const double len = m.xy_length_mm();
    if (len < 1e-9) continue;
    const double h = layers.nominal_mm(m, nozzle, voxel);
    const double hw = std::min(0.5 * stadium_width_mm(m.e_mm * fa / len, h), margin);
    const int steps = std::max(1, static_cast<int>(std::ceil(len / (0.5 * block_mm))));
    for (int s = 0; s <= steps; ++s) {
      const Vec3 q = m.start_mm + (static_cast<double>(s) / steps) * (m.end_mm - m.start_mm);
      const Vec3 lo = (Vec3(q.x() - hw, q.y() - hw, q.z() - h) - f.origin) / block_mm;
      const Vec3 hi = (Vec3(q.x() + hw, q.y() + hw, q.z()) - f.origin) / block_mm;
      for (int bz = std::max(0, static_cast<int>(lo.z())); bz <= std::min(bd.z() - 1, static_cast<int>(hi.z())); ++bz)
        for (int by = std::max(0, static_cast<int>(lo.y())); by <= std::min(bd.y() - 1, static_cast<int>(hi.y())); ++by)
          for (int bx = std::max(0, static_cast<int>(lo.x())); bx <= std::min(bd.x() - 1, static_cast<int>(hi.x())); ++bx) {
            const std::size_t idx = (static_cast<std::size_t>(bz) * static_cast<std::size_t>(bd.y()) +
                                     static_cast<std::size_t>(by)) * static_cast<std::size_t>(bd.x()) +
                                    static_cast<std::size_t>(bx);
            marked[idx / 64] |= std::uint64_t{1} << (idx % 64);
          }
    }
  }
  for (auto w : marked) e.blocks += static_cast<std::size_t>(std::popcount(w));
  e.bytes = static_cast<std::size_t>(grid_bytes(f.dims, e.blocks, tags));
  return e;
}

std::string format_bytes(double bytes) {
  if (bytes >= 1024.0 * 1024 * 1024) return format_fixed(bytes / (1024.0 * 1024 * 1024), 2) + " GiB";
  return format_fixed(bytes / (1024.0 * 1024), 1) + " MiB";
}

Error over_budget(double bytes, double budget, double voxel, double suggested) {
  return usage_error("the deposit needs about " + format_bytes(bytes) + " at voxel " +
                     format_number(voxel) + " mm, over the memory limit of " +
                     format_bytes(budget) + " (--max-memory); use --voxel " +
                     format_number(suggested) + " or raise --max-memory");
}

}  // namespace

Result<DepositEstimate> estimate_deposit(std::span<const Move> moves, const PrinterProfile& profile,
                                         const DepositSettings& settings) {
  if (auto st = check_settings(settings); !st) return st.error();
  return estimate_at(moves, profile, settings.voxel_mm);
}

Result<DepositResult> deposit_moves(std::span<const Move> moves, const PrinterProfile& profile,
                                    const DepositSettings& settings) {
  return detail::DepositRun::moves(moves, profile, detail::DepositRunSettings(settings));
}

Result<DepositResult> detail::DepositRun::moves(std::span<const Move> moves, const PrinterProfile& profile,
                                                const DepositRunSettings& settings) {
  if (auto st = check_settings(settings); !st) return st.error();
  const DepositEstimate e = estimate_at(moves, profile, settings.voxel_mm);
  const auto budget = static_cast<double>(settings.max_memory_bytes);
  if (static_cast<double>(e.bytes) > budget || e.dims.z() > static_cast<int>(kHeightMapMax)) {
    double v = settings.voxel_mm * std::cbrt(static_cast<double>(e.bytes) / (0.9 * budget));
    v = std::max(v, settings.voxel_mm * 1.05);
    for (int attempt = 0; attempt < 8; ++attempt) {
      v = std::ceil(v * 100.0) / 100.0;
      const DepositEstimate again = estimate_at(moves, profile, v);
      if (static_cast<double>(again.bytes) <= budget && again.dims.z() <= static_cast<int>(kHeightMapMax)) break;
      v *= 1.15;
    }
    return over_budget(static_cast<double>(e.bytes), budget, settings.voxel_mm, v);
  }
  auto state = std::make_unique<DepositBuilder::State>(settings, profile, e.origin_mm, e.dims);
  VoxelBlocks::reserve_blocks(state->grid, e.blocks);
  for (const auto& m : moves) state->add(m);
  return state->finish();
}

// ---------------------------------------------------------------------------------------
DepositBuilder::DepositBuilder(std::unique_ptr<State> state) : state_(std::move(state)) {}
DepositBuilder::DepositBuilder(DepositBuilder&&) noexcept = default;
DepositBuilder& DepositBuilder::operator=(DepositBuilder&&) noexcept = default;
DepositBuilder::~DepositBuilder() = default;

Result<DepositBuilder> DepositBuilder::create(const Box3& extent_mm, const PrinterProfile& profile,
                                              const DepositSettings& settings,
                                              double extruded_mm3_hint) {
  if (auto st = check_settings(settings); !st) return st.error();
  const double v = settings.voxel_mm;
  const Frame f = frame_for(extent_mm, 5.0 * profile.nozzle_diameter_mm + 2 * v, v);
  const std::size_t blocks = static_cast<std::size_t>(2.0 * extruded_mm3_hint / (v * v * v * 512.0));
  const double bytes = grid_bytes(f.dims, blocks, 0);
  const auto budget = static_cast<double>(settings.max_memory_bytes);
  if (bytes > budget || f.dims.z() > static_cast<int>(kHeightMapMax)) {
    const double suggested = std::ceil(v * std::cbrt(bytes / (0.9 * budget)) * 100.0) / 100.0;
    return over_budget(bytes, budget, v, std::max(suggested, v + 0.01));
  }
  auto state = std::make_unique<State>(detail::DepositRunSettings(settings), profile, f.origin, f.dims);
  VoxelBlocks::reserve_blocks(state->grid, blocks);
  return DepositBuilder(std::move(state));
}

void DepositBuilder::add(const Move& move) { state_->add(move); }

DepositResult DepositBuilder::finish() {
  DepositResult r = state_->finish();
  state_.reset();
  return r;
}

}  // namespace printtwin
