#pragma once
// GridWriter: the deposit's voxel writes (occupancy bits and tags), applied to the grid in the
// order the sweep makes them, either at once or on a writer thread that runs behind the sweep
// through a ring of records. The sweep reads nothing back from the grid. Without the volume
// squeeze it keeps its own height map, whose top voxel of a column is always occupied (so a
// round join, which fills only free voxels, knows from the map which columns it raises), and
// the writer counts the overlap. The squeeze reads which voxels are free: the sweep then keeps
// its own copy of the occupancy bits (BeadSweep::mirror_writes), counts everything itself and
// sends plain writes (put). The grid, its tags and the counts end the same bit for bit either
// way; the sweep and the writes run side by side on two cores.
//
// The writer thread is a special path (core/plain_path.hpp): with PRINTTWIN_PLAIN=deposit_writer
// (or one hardware thread) the sweep writes the grid itself.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <thread>

#include "printtwin/voxel_grid.hpp"

namespace printtwin::detail {

class GridWriter {
 public:
  /// `threaded`: the writes go to a writer thread (started here; only when fits(grid)); else
  /// they are applied at once.
  GridWriter(VoxelGrid& grid, bool threaded);
  GridWriter(const GridWriter&) = delete;
  GridWriter& operator=(const GridWriter&) = delete;
  ~GridWriter();

  /// Whether a writer thread is worth starting for `grid` (more than one hardware thread,
  /// PRINTTWIN_PLAIN does not list deposit_writer, and its blocks fit the ring's records).
  [[nodiscard]] static bool wanted(const VoxelGrid& grid);
  /// Whether the blocks and layers of `grid` fit the ring's records (else no thread).
  [[nodiscard]] static bool fits(const VoxelGrid& grid);

  /// A bead's voxels (z-slice k of block (bx, by), with tag index `tag`): those occupied
  /// already count as the tile's overlap.
  void bead(int bx, int by, int k, std::uint64_t mask, std::uint32_t tag) {
    push(kBead, bx, by, k, mask, tag);
  }
  /// An end cap's voxels: those occupied already count as overlap.
  void cap(int bx, int by, int k, std::uint64_t mask, std::uint32_t tag) {
    push(kCap, bx, by, k, mask, tag);
  }
  /// A round join's voxels: only the free ones are written; they are credited against the
  /// overlap of the tiles of the same bead that follow (end_tile).
  void join(int bx, int by, int k, std::uint64_t mask, std::uint32_t tag) {
    push(kJoin, bx, by, k, mask, tag);
  }
  /// The end of a bead's tile after a join: its overlap takes what is left of the join's
  /// credit (that material counts as squeezed, not lost).
  void end_tile() { push(kEndTile, 0, 0, 0, 0, tag_); }
  /// The end of a bead laid after a join: the credit left is dropped.
  void end_piece() { push(kEndPiece, 0, 0, 0, 0, tag_); }
  /// Voxels written and counted by the caller (the sweep with the squeeze, which keeps its
  /// own copy of the occupancy): the writer only writes them.
  void put(int bx, int by, int k, std::uint64_t mask, std::uint32_t tag) {
    push(kPut, bx, by, k, mask, tag);
  }

  struct Totals {
    std::size_t overlap = 0;   ///< bead and cap voxels that were occupied already
    std::size_t squeezed = 0;  ///< of them, taken by a join's free voxels
  };
  /// Waits until every write is in the grid (stops the writer thread) and returns the counts.
  /// Rethrows what the writer thread threw.
  Totals finish();

 private:
  enum Kind : std::uint16_t { kBead, kCap, kJoin, kEndTile, kEndPiece, kTag, kPut };
  struct Record {  // 16 bytes; a kTag record holds the tag index in `mask`
    std::uint64_t mask;
    std::uint16_t bx, by, k, kind;
  };
  struct Accounts {
    std::uint32_t tag = 0;
    std::size_t credit = 0, tile_overlap = 0;
    Totals totals;
  };
  static constexpr std::uint64_t kCapacity = std::uint64_t{1} << 15;  ///< records in the ring
  static constexpr std::uint64_t kBatch = 1024;                       ///< published at a time
  static constexpr std::uint64_t kClosed = std::uint64_t{1} << 63;    ///< in head_: no more

  void push(Kind kind, int bx, int by, int k, std::uint64_t mask, std::uint32_t tag) {
    if (!threaded_) {
      acc_.tag = tag;
      apply(kind, bx, by, k, mask);
      return;
    }
    if (tag != tag_) {  // a tag change travels as a record of its own
      tag_ = tag;
      put_record(Record{tag, 0, 0, 0, kTag});
    }
    put_record(Record{mask, static_cast<std::uint16_t>(bx), static_cast<std::uint16_t>(by),
                      static_cast<std::uint16_t>(k), kind});
  }
  void put_record(const Record& r) {
    if (produced_ - tail_seen_ >= kCapacity) wait_for_room();
    ring_[produced_ & (kCapacity - 1)] = r;
    if ((++produced_ & (kBatch - 1)) == 0) publish();
  }
  void wait_for_room();
  void publish(std::uint64_t closed = 0);
  void apply(Kind kind, int bx, int by, int k, std::uint64_t mask);
  void run();

  // The producer's fields, the writer's and the two counters each on their own cache line.
  static constexpr std::size_t kLine = 64;
  alignas(kLine) Record* ring_ = nullptr;
  bool threaded_ = false;
  std::uint32_t tag_ = 0;        // the tag of the records pushed last
  std::uint64_t produced_ = 0;   // records pushed
  std::uint64_t tail_seen_ = 0;  // the producer's last look at tail_
  alignas(kLine) VoxelGrid* grid_;
  Accounts acc_;
  std::exception_ptr error_;
  alignas(kLine) std::atomic<std::uint64_t> head_{0};
  alignas(kLine) std::atomic<std::uint64_t> tail_{0};
  alignas(kLine) std::unique_ptr<Record[]> ring_owner_;
  std::thread thread_;
};

}  // namespace printtwin::detail
