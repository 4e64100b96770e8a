#pragma once
// GridWriter: the deposit's voxel writes (occupancy bits and tag slots), applied to the grid
// in the order they are made, either at once or by a writer thread that runs behind the
// bead sweep through a ring of records. The sweep needs nothing back from the grid while it
// runs (it keeps its own height map and the layer of each column's top voxel), so the two
// halves of the deposit run side by side and the grid ends bit for bit the same.
#include <atomic>
#include <cstdint>
#include <exception>
#include <memory>
#include <thread>

#include "printtwin/voxel_grid.hpp"

namespace printtwin::detail {

class GridWriter {
 public:
  /// `threaded`: writes go to a writer thread (started here); else they are applied at once.
  GridWriter(VoxelGrid& grid, bool threaded);
  GridWriter(const GridWriter&) = delete;
  GridWriter& operator=(const GridWriter&) = delete;
  ~GridWriter();

  /// The tag of the writes that follow (VoxelBlocks::add_tag, in order).
  void tag(const VoxelTag& tag);
  /// ORs `mask` into z-slice k of block (bx, by) with the current tag (VoxelBlocks::write_tile).
  void tile(int bx, int by, int k, std::uint64_t mask);
  /// Waits until every write is in the grid (stops the writer thread); returns how many of
  /// the voxels written were occupied already. Rethrows what the writer thread threw.
  std::size_t finish();

 private:
  struct Record {
    std::uint64_t bits;      ///< tile: the mask; tag: line | layer << 32
    std::uint16_t bx, by;    ///< tile: the block; tag: by = feature
    std::uint16_t k;         ///< tile: the voxel layer
    std::uint16_t kind;      ///< 0 tile, 1 tag
  };
  static constexpr std::uint64_t kCapacity = std::uint64_t{1} << 16;  ///< records in the ring (1 MiB)
  static constexpr std::uint64_t kBatch = 4096;  ///< records published at a time
  static constexpr std::uint64_t kClosed = std::uint64_t{1} << 63;  ///< in head_: no more records

  void push(const Record& r);
  void publish(std::uint64_t closed = 0);
  void apply(const Record& r);
  void run();

  // The producer's fields, the writer's fields and the two counters each sit on their own
  // cache line: the writer updates tag_index_ and overlap_ with every record and the
  // producer produced_ with every push, and on one line each write would take the line
  // from the other core (measured: push and apply were ~18 % of simulate + deposit).
  static constexpr std::size_t kLine = 64;
  // Producer (the sweep's thread).
  alignas(kLine) Record* ring_ = nullptr;  // records (threaded only); owned by ring_owner_
  bool threaded_ = false;
  bool finished_ = false;
  std::uint64_t produced_ = 0;   // producer's own count
  std::uint64_t tail_seen_ = 0;  // producer's last look at tail_
  // Writer (the writer thread, or the producer when not threaded).
  alignas(kLine) VoxelGrid* grid_;
  std::uint32_t tag_index_ = 0;
  std::size_t overlap_ = 0;
  std::exception_ptr error_;  // set by the writer thread
  // Ring (threaded only): the producer writes records, then publishes head_; the writer
  // applies them and advances tail_. Each side blocks with atomic wait when it must.
  alignas(kLine) std::atomic<std::uint64_t> head_{0};
  alignas(kLine) std::atomic<std::uint64_t> tail_{0};
  alignas(kLine) std::unique_ptr<Record[]> ring_owner_;
  std::thread thread_;
};

}  // namespace printtwin::detail
