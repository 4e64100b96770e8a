#include "deposit/grid_writer.hpp"

#include "core/bits.hpp"
#include "deposit/voxel_blocks.hpp"

namespace printtwin::detail {

GridWriter::GridWriter(VoxelGrid& grid, bool threaded) : grid_(&grid) {
  if (!threaded) return;
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

void GridWriter::tag(const VoxelTag& t) {
  push(Record{static_cast<std::uint32_t>(t.line) | static_cast<std::uint64_t>(static_cast<std::uint32_t>(t.layer)) << 32,
              0, static_cast<std::uint16_t>(t.feature), 0, 1});
}

void GridWriter::tile(int bx, int by, int k, std::uint64_t mask) {
  push(Record{mask, static_cast<std::uint16_t>(bx), static_cast<std::uint16_t>(by), static_cast<std::uint16_t>(k), 0});
}

void GridWriter::apply(const Record& r) {
  if (r.kind == 1) {
    tag_index_ = VoxelBlocks::add_tag(*grid_, VoxelTag{static_cast<std::uint32_t>(r.bits), static_cast<std::int32_t>(r.bits >> 32),
                                        static_cast<Feature>(r.by)});
    return;
  }
  const std::size_t fresh = VoxelBlocks::write_tile(*grid_, r.bx, r.by, r.k, r.bits, tag_index_);
  overlap_ += static_cast<std::size_t>(popcount64(r.bits)) - fresh;
}

void GridWriter::push(const Record& r) {
  if (!threaded_) {
    apply(r);
    return;
  }
  while (produced_ - tail_seen_ >= kCapacity) {  // full: wait for the writer
    tail_seen_ = tail_.load(std::memory_order_acquire);
    if (produced_ - tail_seen_ < kCapacity) break;
    publish();
    tail_.wait(tail_seen_, std::memory_order_acquire);
  }
  ring_[produced_ & (kCapacity - 1)] = r;
  if (++produced_ % kBatch == 0) publish();
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
        for (std::uint64_t i = done; i < available; ++i) apply(ring_[i & (kCapacity - 1)]);
      } catch (...) {
        error_ = std::current_exception();  // the rest is drained unapplied; finish() rethrows
      }
    }
    done = available;
    tail_.store(done, std::memory_order_release);
    tail_.notify_one();
  }
}

std::size_t GridWriter::finish() {
  if (!finished_ && thread_.joinable()) {
    publish(kClosed);
    thread_.join();
    if (error_) std::rethrow_exception(error_);
  }
  finished_ = true;
  return overlap_;
}

}  // namespace printtwin::detail
