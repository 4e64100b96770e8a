// The deposit's grid writes (see grid_writer.hpp).
#include "deposit/grid_writer.hpp"

#include <algorithm>

#include "core/bits.hpp"
#include "core/plain_path.hpp"
#include "deposit/voxel_blocks.hpp"

namespace printtwin::detail {

GridWriter::GridWriter(VoxelGrid& grid, bool threaded) : grid_(&grid) {
  if (!threaded || !fits(grid)) return;
  ring_owner_ = std::make_unique<Record[]>(kCapacity);
  ring_ = ring_owner_.get();
  threaded_ = true;
  thread_ = std::thread([this] { run(); });
}

GridWriter::~GridWriter() {
  if (thread_.joinable()) {
    publish(kClosed);
    thread_.join();
  }
}

bool GridWriter::fits(const VoxelGrid& grid) {
  const Eigen::Vector3i blocks = VoxelBlocks::block_dims(grid);
  return blocks.x() <= 0xFFFF && blocks.y() <= 0xFFFF && grid.dims().z() <= 0xFFFF;
}

bool GridWriter::wanted(const VoxelGrid& grid) {
  return std::thread::hardware_concurrency() > 1 && fits(grid) && !plain_path("deposit_writer");
}

void GridWriter::apply(Kind kind, int bx, int by, int k, std::uint64_t mask) {
  Accounts& a = acc_;
  switch (kind) {
    case kTag:
      a.tag = static_cast<std::uint32_t>(mask);
      return;
    case kEndTile: {
      a.totals.overlap += a.tile_overlap;
      const std::size_t used = std::min(a.credit, a.tile_overlap);
      a.credit -= used;
      a.totals.squeezed += used;
      a.tile_overlap = 0;
      return;
    }
    case kEndPiece:
      a.credit = 0;
      return;
    case kJoin: {
      const std::uint64_t* occ = VoxelBlocks::block_occupancy(*grid_, bx, by, k >> 3);
      const std::uint64_t free = mask & ~(occ != nullptr ? occ[k & 7] : 0);
      if (free != 0) a.credit += VoxelBlocks::write_tile(*grid_, bx, by, k, free, a.tag);
      return;
    }
    case kPut:
      VoxelBlocks::write_tile(*grid_, bx, by, k, mask, a.tag);
      return;
    case kBead:
    case kCap: {
      const std::size_t fresh = VoxelBlocks::write_tile(*grid_, bx, by, k, mask, a.tag);
      const auto occupied = static_cast<std::size_t>(popcount64(mask)) - fresh;
      // A bead's tile overlap waits for its end_tile only while a join's credit is left.
      if (kind == kBead && a.credit > 0)
        a.tile_overlap += occupied;
      else
        a.totals.overlap += occupied;
      return;
    }
  }
}

void GridWriter::wait_for_room() {
  for (;;) {
    tail_seen_ = tail_.load(std::memory_order_acquire);
    if (produced_ - tail_seen_ < kCapacity) return;
    publish();
    tail_.wait(tail_seen_, std::memory_order_acquire);
  }
}

void GridWriter::publish(std::uint64_t closed) {
  head_.store(produced_ | closed, std::memory_order_release);
  head_.notify_one();
}

void GridWriter::run() {
  std::uint64_t done = 0;
  for (;;) {
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    const std::uint64_t available = head & ~kClosed;
    if (available == done) {
      if ((head & kClosed) != 0) return;
      head_.wait(head, std::memory_order_acquire);
      continue;
    }
    if (!error_) {
      try {
        for (std::uint64_t i = done; i < available; ++i) {
          const Record& r = ring_[i & (kCapacity - 1)];
          apply(static_cast<Kind>(r.kind), r.bx, r.by, r.k, r.mask);
        }
      } catch (...) {
        error_ = std::current_exception();  // the rest drains unapplied; finish() rethrows
      }
    }
    done = available;
    tail_.store(done, std::memory_order_release);
    tail_.notify_one();
  }
}

GridWriter::Totals GridWriter::finish() {
  if (thread_.joinable()) {
    publish(kClosed);
    thread_.join();
    if (error_) std::rethrow_exception(error_);
  }
  return acc_.totals;
}

}  // namespace printtwin::detail
