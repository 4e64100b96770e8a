// Step 2 of the outer surface: the flood from outside, block by block from the padding, in
// waves. Every block of a wave grows its outside by a fill within the block, in parallel, and
// what reaches its faces seeds the neighbours for the next wave. An open block (no part voxel
// within the seal radius) is wholly outside as soon as anything reaches it (R within a block
// is a box, so connected). The outside found is the one component of the open voxels that
// holds the padding, whatever the order blocks are reached in. The inside of a part (sparse
// infill behind its walls) is never visited.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "deviation/surface_steps.hpp"

namespace printtwin::surface_blocks {

namespace {

class Flood {
 public:
  Flood(const SurfaceRegion& region, const PartBlocks& part, int seal_r)
      : region_(region), box_(region.box) {
    const std::size_t n = box_.size();
    out_.kind.assign(n, OutsideFlood::kUntouched);
    out_.slot.assign(n, 0);
    queued_.assign(n, 0);
    // A block no part voxel comes within r of is open all through (within R).
    near_occ_.resize(n);
    for (std::size_t i = 0; i < n; ++i) near_occ_[i] = part.of[i] != nullptr ? 1 : 0;
    dilate_flags(near_occ_, box_, (seal_r + kE - 1) / kE);
    step_ = {-static_cast<std::ptrdiff_t>(box_.n.z()),
             box_.n.z(),
             -static_cast<std::ptrdiff_t>(box_.n.z()) * box_.n.x(),
             static_cast<std::ptrdiff_t>(box_.n.z()) * box_.n.x(),
             -1,
             1};
  }

  /// The whole flood; `blocked` is the part dilated by the seal radius (its memory is freed
  /// when the flood ends).
  template <class Blocked>
  OutsideFlood run(Blocked& blocked) {
    seed_padding();
    while (!next_wave_.empty()) {
      wave_.swap(next_wave_);
      next_wave_.clear();
      prepare_open(blocked);
      grow_wave();
      // The seeds, between waves (OR is commutative: the order they come in changes nothing).
      for (const auto& w : turned_whole_) next_wave_.insert(next_wave_.end(), w.begin(), w.end());
      for (auto& f : found_)
        for (const Seed& sd : f) add_seed(sd.to, sd.bits);
    }
    return std::move(out_);
  }

 private:
  // Wave entries carry their block's coordinates (no divisions to recover them).
  struct Queued {
    std::uint32_t i;
    std::int32_t x, y, z;
  };
  struct Seed {
    Queued to;
    Cube bits;
  };

  /// Seeds for a block, between waves (one thread): an open block turns whole; another gets
  /// its state (open voxels computed before the wave), the seed pending, and a place in the
  /// next wave.
  void add_seed(const Queued& q, const Cube& seed) {
    const std::size_t i = q.i;
    if (out_.kind[i] == OutsideFlood::kWhole) return;
    if (near_occ_[i] == 0) {
      out_.kind[i] = OutsideFlood::kWhole;
      next_wave_.push_back(q);
      return;
    }
    if (out_.kind[i] == OutsideFlood::kUntouched) {
      out_.kind[i] = OutsideFlood::kPartial;
      out_.slot[i] = open_.push(Cube{});
      out_.outside.push(Cube{});
      pending_.push(Cube{});
      has_open_.push_back(0);
    }
    Cube& p = pending_[out_.slot[i]];
    std::uint64_t any_bits = 0;
    for (std::size_t z = 0; z < kE; ++z) {
      p[z] |= seed[z];
      any_bits |= seed[z];
    }
    if (any_bits != 0 && queued_[i] == 0) {
      queued_[i] = 1;
      next_wave_.push_back(q);
    }
  }

  /// Seeds: the padding, in the blocks on the box's faces.
  void seed_padding() {
    const BlockBox& box = box_;
    for (int by = box.lo.y(); by < box.lo.y() + box.n.y(); ++by)
      for (int bx = box.lo.x(); bx < box.lo.x() + box.n.x(); ++bx)
        for (int bz = box.lo.z(); bz < box.lo.z() + box.n.z(); ++bz) {
          const bool face = bx == box.lo.x() || by == box.lo.y() || bz == box.lo.z() ||
                            bx == box.lo.x() + box.n.x() - 1 || by == box.lo.y() + box.n.y() - 1 ||
                            bz == box.lo.z() + box.n.z() - 1;
          if (!face) continue;
          const Cube r = region_.region_cube(bx, by, bz), in = region_.interior_cube(bx, by, bz);
          Cube pad;
          for (std::size_t z = 0; z < kE; ++z) pad[z] = r[z] & ~in[z];
          if (any(pad))
            add_seed({static_cast<std::uint32_t>(box.index(bx, by, bz)), bx, by, bz}, pad);
        }
  }

  /// The open voxels of the wave's new partial blocks: their dilation's stages prepared,
  /// then each block's, in parallel.
  template <class Blocked>
  void prepare_open(Blocked& blocked) {
    need_open_.clear();
    for (const Queued& q : wave_)
      if (out_.kind[q.i] == OutsideFlood::kPartial && has_open_[out_.slot[q.i]] == 0)
        need_open_.push_back(q.i);
    if (need_open_.empty()) return;
    blocked.prepare(need_open_);
    tbb::parallel_for(std::size_t{0}, need_open_.size(), [&](std::size_t k) {
      const std::uint32_t i = need_open_[k];
      const Eigen::Vector3i b = box_.coords(i);
      Cube e = region_.region_cube(b.x(), b.y(), b.z());
      Cube d;
      if (blocked.top_of(b.x(), b.y(), b.z(), d))
        for (std::size_t z = 0; z < kE; ++z) e[z] &= ~d[z];
      open_[out_.slot[i]] = e;
      has_open_[out_.slot[i]] = 1;
    });
  }

  /// A partial block's pending seeds flooded through its open voxels: the voxels newly
  /// outside (false when none).
  bool grow_partial(const Queued& q, Cube& grown) {
    queued_[q.i] = 0;
    const std::uint32_t k = out_.slot[q.i];
    Cube o = out_.outside[k];
    bool news = false;
    for (std::size_t z = 0; z < kE; ++z) {
      const std::uint64_t add = pending_[k][z] & open_[k][z] & ~o[z];
      o[z] |= add;
      news = news || add != 0;
    }
    pending_[k] = Cube{};
    if (!news) return false;
    o = flood_cube(open_[k], o);
    for (std::size_t z = 0; z < kE; ++z) grown[z] = o[z] & ~out_.outside[k][z];
    out_.outside[k] = o;
    return true;
  }

  /// What a block grew passed on to its six neighbours: an open neighbour turns whole here
  /// (the one thread that claims it queues it); other blocks change kind only between waves.
  void pass_on(const Queued& q, const Cube& grown, std::vector<Seed>& mine,
               std::vector<Queued>& whole_now) {
    // Whether the grown voxels touch each face (transfer(grown, d) not empty), from their
    // union: a transfer is made only for a seed.
    std::uint64_t all = 0;
    for (const std::uint64_t w : grown) all |= w;
    const std::array<bool, 6> touches{(all & kX0) != 0, (all & kX7) != 0, (all & kY0) != 0,
                                      (all & kY7) != 0, grown[0] != 0,    grown[kE - 1] != 0};
    for (int d = 0; d < 6; ++d) {
      if (!touches[static_cast<std::size_t>(d)]) continue;
      const int nbx = q.x + kDirs[d][0], nby = q.y + kDirs[d][1], nbz = q.z + kDirs[d][2];
      if (!box_.contains(nbx, nby, nbz)) continue;
      const auto n = static_cast<std::uint32_t>(static_cast<std::ptrdiff_t>(q.i) +
                                                step_[static_cast<std::size_t>(d)]);
      std::atomic_ref<std::uint8_t> nk(out_.kind[n]);
      if (nk.load(std::memory_order_relaxed) == OutsideFlood::kWhole) continue;
      if (near_occ_[n] == 0) {
        std::uint8_t expected = OutsideFlood::kUntouched;
        if (nk.compare_exchange_strong(expected, OutsideFlood::kWhole, std::memory_order_relaxed))
          whole_now.push_back({n, nbx, nby, nbz});
      } else {
        mine.push_back({{n, nbx, nby, nbz}, transfer(grown, d)});
      }
    }
  }

  /// One wave: every block grows, in parallel; the seeds for the next wave are gathered.
  void grow_wave() {
    for (auto& f : found_) f.clear();
    for (auto& w : turned_whole_) w.clear();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, wave_.size(), 256),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        auto& mine = found_.local();
                        auto& whole_now = turned_whole_.local();
                        for (std::size_t w = range.begin(); w != range.end(); ++w) {
                          const Queued q = wave_[w];
                          Cube grown;
                          if (out_.kind[q.i] == OutsideFlood::kWhole)
                            grown = region_.region_cube(q.x, q.y, q.z);
                          else if (!grow_partial(q, grown))
                            continue;
                          pass_on(q, grown, mine, whole_now);
                        }
                      });
  }

  const SurfaceRegion& region_;
  const BlockBox& box_;
  OutsideFlood out_;
  std::vector<std::uint8_t> near_occ_, queued_;
  CubePool open_, pending_;               // per slot: open voxels (E), seeds not yet flooded
  std::vector<std::uint8_t> has_open_;    // per slot: open (E) computed
  std::array<std::ptrdiff_t, 6> step_{};  // index steps to the six neighbours
  std::vector<Queued> wave_, next_wave_;
  std::vector<std::uint32_t> need_open_;
  tbb::enumerable_thread_specific<std::vector<Seed>> found_;
  tbb::enumerable_thread_specific<std::vector<Queued>> turned_whole_;
};

}  // namespace

OutsideFlood flood_outside(const SurfaceRegion& region, const PartBlocks& part, int seal_r) {
  const BlockBox& box = region.box;
  const auto part_cube = [&](int bx, int by, int bz) { return part.at(box, bx, by, bz); };
  const auto interior_cube = [&](int bx, int by, int bz) {
    return region.interior_cube(bx, by, bz);
  };
  // Held only through the flood.
  DilatedField<decltype(part_cube), decltype(interior_cube)> blocked(box, seal_r, part_cube,
                                                                     interior_cube);
  Flood flood(region, part, seal_r);
  return flood.run(blocked);
}

}  // namespace printtwin::surface_blocks
