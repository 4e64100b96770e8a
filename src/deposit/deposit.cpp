// The deposit: extruding moves -> voxels, in G-code order.
//
// DepositBuilder::State drives the stages of each bead: the bead model (bead_model.cpp)
// gives its section from the height map (height_map.cpp), the support test
// (support.cpp) samples what lies beneath it, and the sweep (sweep.cpp) turns it into
// voxels and squeezes the material that falls on earlier plastic into the free voxels
// beside and below it. This file also holds the memory estimate and the public entry points.
#include "printtwin/deposit.hpp"
#include "core/bits.hpp"
#include "deposit/deposit_run.hpp"
#include "deposit/voxel_blocks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "deposit/bead_model.hpp"
#include "deposit/droop_probe.hpp"
#include "deposit/height_map.hpp"
#include "deposit/support.hpp"
#include "deposit/sweep.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

using detail::BeadSection;
using detail::HeightMap;
using detail::is_bead;
using detail::is_support;
using detail::LayerTracker;
using detail::PendingBead;

namespace {
constexpr std::size_t kHeightMapMax = HeightMap::kMaxRows;  // rows of the height map
}  // namespace

// ---------------------------------------------------------------------------------------
struct DepositBuilder::State {
  detail::DepositRunSettings settings;
  double voxel = 0.05;
  double filament_area_mm2 = 0;
  double nozzle_mm = 0.4;
  VoxelGrid grid;
  HeightMap map;
  LayerTracker layers;
  std::optional<PendingBead> pending;
  std::vector<double> gaps_;  // scratch of bead_section
  BeadSection last_section;   // of the bead laid last
  detail::SupportTracker support;
  detail::BeadSweep sweeper;
  detail::DroopProbe droop;  // sag, droop, elephant's foot
  // The grid's writes: on a writer thread when there is a second core (grid_writer.hpp).
  std::unique_ptr<detail::GridWriter> writer;

  double extruded_mm3 = 0;
  std::size_t beads = 0;
  std::size_t skipped = 0;
  std::uint32_t tag = 0;            // the pending bead's tag index
  std::size_t overlap_voxels = 0;   // bead voxels that fell on occupied ones
  std::size_t squeezed_voxels = 0;  // free voxels that took their material

  State(const detail::DepositRunSettings& s, const PrinterProfile& p, const Vec3& origin,
        const Eigen::Vector3i& dims)
      : settings(s),
        voxel(s.voxel_mm),
        filament_area_mm2(p.filament_area_mm2()),
        nozzle_mm(p.nozzle_diameter_mm),
        grid(s.voxel_mm, origin, dims),
        map(s.voxel_mm, origin, dims.x(), dims.y(),
            static_cast<std::size_t>(detail::VoxelBlocks::block_dims(grid).x()),
            static_cast<std::size_t>(detail::VoxelBlocks::block_dims(grid).y())),
        support(s.support_fraction, s.min_unsupported_mm, s.voxel_mm),
        sweeper(grid, s.exhaustive_tiles),
        droop(detail::DroopModel::from(p), s.voxel_mm) {
    // Without a writer thread (one core, PRINTTWIN_PLAIN=deposit_writer) the sweep writes the
    // grid itself; `at_once` (the tests) sends the writes through the writer on this thread.
    using Writes = detail::DepositRunSettings::Writes;
    const bool threaded = s.writes == Writes::thread ||
                          (s.writes == Writes::automatic && detail::GridWriter::wanted(grid));
    if (threaded || s.writes == Writes::at_once) {
      writer = std::make_unique<detail::GridWriter>(grid, threaded);
      // The squeeze reads the grid: the sweep keeps its own copy of the occupancy.
      if (s.conserve_volume)
        sweeper.mirror_writes(writer.get());
      else
        sweeper.defer_writes(writer.get());
    }
  }

  // -- moves -----------------------------------------------------------------------------
  void add(const Move& m) {
    if (!is_bead(m)) {
      flush(std::nullopt, true);
      return;
    }
    extruded_mm3 += m.e_mm * filament_area_mm2;
    if (m.xy_length_mm() < 1e-9) {  // Z-only or in-place extrusion: a blob we do not model
      ++skipped;
      flush(std::nullopt, true);
      return;
    }
    const Vec2 d = (m.end_mm - m.start_mm).head<2>().normalized();
    bool continues = false;
    bool mitred = false;
    Vec2 m0 = d;
    Vec2 dp = d;  // the previous bead's direction
    if (pending) {
      const Move& p = pending->move;
      continues = p.layer == m.layer && (p.end_mm - m.start_mm).norm() < detail::kJoinTolMm;
      if (continues) {
        dp = (p.end_mm - p.start_mm).head<2>().normalized();
        if (dp.dot(d) >= detail::kMitreMinCos) {
          m0 = (dp + d).normalized();
          mitred = true;
        }
      }
      // The previous bead ends on the shared mitre plane, or square when not mitred.
      flush(mitred ? std::optional<Vec2>(m0) : std::nullopt, !continues);
    }
    PendingBead pb;
    pb.move = m;
    pb.nominal_h_mm = layers.nominal_mm(m, nozzle_mm, voxel);
    pb.continues_path = continues;
    pb.round_start = continues && !mitred;
    pb.join_h_mm = last_section.h_mm;
    pb.join_w_mm = last_section.w_mm;
    pb.join_d = dp;
    pb.m0 = m0;
    tag = detail::VoxelBlocks::add_tag(
        grid, VoxelTag{static_cast<std::uint32_t>(std::max(m.line, 0L)), m.layer, m.feature});
    pending = pb;
  }

  /// Lays the pending bead; `m1` is its end cut normal (nullopt: square cut); `path_end`: the
  /// path stops there (a round end cap).
  void flush(const std::optional<Vec2>& m1, bool path_end) {
    if (!pending) return;
    const PendingBead pb = *pending;
    pending.reset();
    const Vec2 d = (pb.move.end_mm - pb.move.start_mm).head<2>().normalized();
    lay(pb, m1.value_or(d), path_end);
  }

  void lay(const PendingBead& pb, const Vec2& m1, bool path_end) {
    const Move& mv = pb.move;
    const double len_mm = mv.xy_length_mm();
    const double area_mm2 = mv.e_mm * filament_area_mm2 / len_mm;
    const Vec3 a = mv.start_mm;
    const Vec3 b = mv.end_mm;
    const Vec2 d = (b - a).head<2>() / len_mm;
    const Vec2 n(-d.y(), d.x());
    const int samples = std::max(1, static_cast<int>(std::ceil(len_mm * (1.0 / voxel))));
    // A path's start and end are round (the nozzle's footprint is a disc), made of the
    // bead's own material.
    const bool cap_start = !pb.continues_path;
    const int caps = (cap_start ? 1 : 0) + (path_end ? 1 : 0);
    BeadSection s = detail::bead_section(pb, area_mm2, samples, caps, map, voxel, gaps_);
    const double squeeze_mm = settings.conserve_volume ? 0.5 * nozzle_mm : 0.0;
    // A flattened bead widens by up to the squeeze's reach beyond each nominal edge; one that
    // may form the part's sides as much, but all towards the inside (not at all where that is
    // unclear), its outer edge staying where it is.
    double overflow_mm2 = 0;
    Vec3 inward = Vec3::Zero();
    if (squeeze_mm > 0) {
      const double w_nominal = detail::capped_section(area_mm2, pb.nominal_h_mm, len_mm, caps).w_mm;
      int side = 0;
      if (detail::may_form_sides(mv.feature) && s.w_mm > w_nominal)
        side = detail::inside_side(map, a, b, n, 0.5 * w_nominal, voxel);
      const bool sided = detail::may_form_sides(mv.feature);
      overflow_mm2 = detail::bound_flattened(
          s, w_nominal, sided && side == 0 ? 0.0 : 2.0 * squeeze_mm, len_mm, caps);
      if (side != 0) {
        const double shift = 0.5 * side * (s.w_mm - w_nominal);
        inward = Vec3(shift * n.x(), shift * n.y(), 0.0);
      }
    }
    const std::int32_t code = HeightMap::layer_code(mv.layer, is_support(mv.feature));
    detail::SweptBead bead{a + inward, b + inward, d,      n,    pb.m0,
                           m1,         s.h_mm,     s.w_mm, code, squeeze_mm};
    bead.overflow_mm2 = overflow_mm2;
    if (pb.round_start) {  // the wider of the two beads' sections
      const bool prev_wider = pb.join_w_mm > s.w_mm;
      bead.join_h_mm = prev_wider ? pb.join_h_mm : s.h_mm;
      bead.join_w_mm = prev_wider ? pb.join_w_mm : s.w_mm;
      bead.join_d = pb.join_d;
    }
    bead.cap_start = cap_start;
    bead.keeps_sides = detail::may_form_sides(mv.feature);
    bead.rise_voxels = detail::rise_voxels(mv.feature);
    bead.cap_end = path_end;
    last_section = s;
    droop.elephant_foot(bead, mv.feature, detail::section_area_mm2(s), map);
    droop.begin_bead(mv, bead.a_mm, bead.b_mm, samples, bead.h_mm, bead.w_mm, map);
    support.check_bead(mv, bead.a_mm, bead.b_mm, n, samples, bead.h_mm, bead.w_mm,
                       pb.continues_path, map, &droop);
    const auto laid = droop.lay(bead, sweeper, grid, tag, map);
    overlap_voxels += laid.overlap;
    squeezed_voxels += laid.squeezed;
    ++beads;
  }

  // -- results ---------------------------------------------------------------------------
  DepositResult finish() {
    flush(std::nullopt, true);
    support.close_stretch(false);
    if (writer) {
      const detail::GridWriter::Totals t = writer->finish();
      overlap_voxels += t.overlap;
      squeezed_voxels += t.squeezed;
    }
    DepositResult r;
    r.voxel_mm = voxel;
    r.voxels = grid.count();
    r.volume_mm3 = static_cast<double>(r.voxels) * voxel * voxel * voxel;
    r.extruded_mm3 = extruded_mm3;
    r.overlap_mm3 = static_cast<double>(overlap_voxels) * voxel * voxel * voxel;
    r.squeezed_mm3 = static_cast<double>(squeezed_voxels) * voxel * voxel * voxel;
    r.beads = beads;
    r.skipped_moves = skipped;
    r.unsupported_mm = support.unsupported_mm();
    r.bbox_mm = occupied_bbox();
    r.unsupported = support.take_stretches();
    r.findings = detail::make_findings(r.unsupported);
    r.memory_bytes = grid.memory_bytes() + map.memory_bytes();
    map.release();
    r.grid = std::move(grid);
    return r;
  }

  [[nodiscard]] Box3 occupied_bbox() const {
    Eigen::Vector3i lo = Eigen::Vector3i::Constant(std::numeric_limits<int>::max());
    Eigen::Vector3i hi = Eigen::Vector3i::Constant(std::numeric_limits<int>::min());
    // Min and max do not depend on the order: the allocated blocks as they come, not the
    // whole directory (most of which, over the bed around the part, was never touched).
    detail::VoxelBlocks::visit_blocks_as_allocated(
        grid, [&](const detail::VoxelBlocks::BlockView& blk) {
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
};

// ---------------------------------------------------------------------------------------
namespace {

Status check_settings(const DepositSettings& s) {
  if (!(s.voxel_mm >= 0.001 && s.voxel_mm <= 10.0))
    return usage_error("voxel size must be between 0.001 and 10 mm, got " +
                       format_number(s.voxel_mm));
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
  return bd.prod() * 4.0 + static_cast<double>(blocks) * detail::VoxelBlocks::kBlockBytes +
         static_cast<double>(dims.x()) * dims.y() * HeightMap::kColumnBytes +  // the height map
         static_cast<double>(tags) * sizeof(VoxelTag) + 1024.0 * detail::VoxelBlocks::kBlockBytes;
}

/// The estimate at one voxel size: bead footprints marked block by block.
DepositEstimate estimate_at(std::span<const Move> moves, const PrinterProfile& profile,
                            double voxel) {
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
      for (int bz = std::max(0, static_cast<int>(lo.z()));
           bz <= std::min(bd.z() - 1, static_cast<int>(hi.z())); ++bz)
        for (int by = std::max(0, static_cast<int>(lo.y()));
             by <= std::min(bd.y() - 1, static_cast<int>(hi.y())); ++by)
          for (int bx = std::max(0, static_cast<int>(lo.x()));
               bx <= std::min(bd.x() - 1, static_cast<int>(hi.x())); ++bx) {
            const std::size_t idx =
                (static_cast<std::size_t>(bz) * static_cast<std::size_t>(bd.y()) +
                 static_cast<std::size_t>(by)) *
                    static_cast<std::size_t>(bd.x()) +
                static_cast<std::size_t>(bx);
            marked[idx / 64] |= std::uint64_t{1} << (idx % 64);
          }
    }
  }
  for (auto w : marked) e.blocks += static_cast<std::size_t>(popcount64(w));
  e.bytes = static_cast<std::size_t>(grid_bytes(f.dims, e.blocks, tags));
  return e;
}

std::string format_bytes(double bytes) {
  if (bytes >= 1024.0 * 1024 * 1024)
    return format_fixed(bytes / (1024.0 * 1024 * 1024), 2) + " GiB";
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

Result<DepositResult> detail::DepositRun::moves(std::span<const Move> moves,
                                                const PrinterProfile& profile,
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
      if (static_cast<double>(again.bytes) <= budget &&
          again.dims.z() <= static_cast<int>(kHeightMapMax))
        break;
      v *= 1.15;
    }
    return over_budget(static_cast<double>(e.bytes), budget, settings.voxel_mm, v);
  }
  auto state = std::make_unique<DepositBuilder::State>(settings, profile, e.origin_mm, e.dims);
  detail::VoxelBlocks::reserve_blocks(state->grid, e.blocks);
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
  const std::size_t blocks =
      static_cast<std::size_t>(2.0 * extruded_mm3_hint / (v * v * v * 512.0));
  const double bytes = grid_bytes(f.dims, blocks, 0);
  const auto budget = static_cast<double>(settings.max_memory_bytes);
  if (bytes > budget || f.dims.z() > static_cast<int>(kHeightMapMax)) {
    const double suggested = std::ceil(v * std::cbrt(bytes / (0.9 * budget)) * 100.0) / 100.0;
    return over_budget(bytes, budget, v, std::max(suggested, v + 0.01));
  }
  auto state =
      std::make_unique<State>(detail::DepositRunSettings(settings), profile, f.origin, f.dims);
  detail::VoxelBlocks::reserve_blocks(state->grid, blocks);
  return DepositBuilder(std::move(state));
}

void DepositBuilder::add(const Move& move) { state_->add(move); }

DepositResult DepositBuilder::finish() {
  DepositResult r = state_->finish();
  state_.reset();
  return r;
}

}  // namespace printtwin
