#pragma once
// Private to src/deposit/ and its tests: switches that change how the deposit runs, never
// what it lays.
#include <span>

#include "printtwin/deposit.hpp"

namespace printtwin::detail {

/// DepositSettings plus the deposit's run switches.
struct DepositRunSettings : DepositSettings {
  DepositRunSettings() = default;
  explicit DepositRunSettings(const DepositSettings& settings) : DepositSettings(settings) {}
  /// Test every voxel of each bead's bounding box instead of the footprint's tiles (slow;
  /// the tests use it to check that the footprint bounds never miss a voxel).
  bool exhaustive_tiles = false;
  /// How the grid's writes are made: `automatic` (a writer thread when GridWriter::wanted(),
  /// else direct), `direct` (by the sweep into the grid), `at_once` (through the GridWriter on
  /// the sweep's thread) or `thread` (on a writer thread). All give the same grid; the tests
  /// compare them.
  enum class Writes { automatic, direct, at_once, thread };
  Writes writes = Writes::automatic;
};

/// deposit_moves with the run switches.
struct DepositRun {
  [[nodiscard]] static Result<DepositResult> moves(std::span<const Move> moves,
                                                   const PrinterProfile& profile,
                                                   const DepositRunSettings& settings);
};

}  // namespace printtwin::detail
