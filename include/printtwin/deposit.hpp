#pragma once
// Deposit: the material the nozzle lays down, as voxels. Each extruding Move lays a bead
// whose cross-section area is the extruded volume over the move's length, whose height is
// the gap between the nozzle and what lies beneath (bed or earlier deposit), and whose width
// follows the stadium model of Slic3r/PrusaSlicer, w = area / h + (1 - pi/4) h. The bead is
// swept along the move (mitred at the joints of a continuous path) and voxelised so that the
// deposited volume equals the extruded volume where beads do not overlap. Beads that lack
// support beneath (extrusion into air) become findings. Exports: OctoMap .bt/.ot, PLY of the
// outer surface voxels, and the `deposit` JSON fragment of the simulate report.
// docs/deposit.md describes the model, the findings and the file formats.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/result.hpp"
#include "printtwin/toolpath.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin {

namespace detail {
struct DepositRun;
}  // namespace detail

struct DepositSettings {
  double voxel_mm = 0.05;  ///< voxel edge
  /// A bead is supported when at least this fraction of its width rests on the bed or on
  /// earlier deposit.
  double support_fraction = 0.5;
  /// The job stops before allocating when its estimated memory exceeds this.
  std::size_t max_memory_bytes = std::size_t{2} << 30;
  /// Unsupported stretches shorter than this are not reported (still in `unsupported`).
  double min_unsupported_mm = 1.0;
  /// Conserve volume: the part of a bead that falls on earlier plastic squeezes into free
  /// voxels near its section, up to half the nozzle diameter away (beside and below it first;
  /// a bead that may form the outer surface never past an open side's edge nor above its
  /// top; a bead flattened over earlier plastic no wider than half a nozzle beyond its nominal
  /// edges). Off (`--no-conserve-volume` on simulate and verify): that material is lost (it
  /// still counts in overlap_mm3). On by default (docs/deposit.md).
  bool conserve_volume = true;
};

/// A run of consecutive unsupported bead samples along one continuous extrusion path.
struct UnsupportedStretch {
  int layer = -1;
  long first_line = 0;  ///< G-code line of the first move of the stretch
  long last_line = 0;   ///< G-code line of the last move of the stretch
  Vec3 start_mm = Vec3::Zero();
  Vec3 end_mm = Vec3::Zero();
  double length_mm = 0;
  /// Supported at both ends (a bridge); otherwise a cantilever that droops.
  bool bridge = false;
  Feature feature = Feature::unknown;
  /// The most the stretch's bead is lowered by sag or droop (mm; docs/deposit.md, "Sag,
  /// droop and elephant's foot").
  double drop_mm = 0;
  /// Part of it is beyond the fall limit: it falls onto what is below or dangles.
  bool falls = false;
};

/// What a deposit job will need, computed before allocating anything.
struct DepositEstimate {
  Vec3 origin_mm = Vec3::Zero();
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();  ///< grid size in voxels
  std::size_t blocks = 0;                          ///< 8^3-voxel blocks the beads touch
  std::size_t bytes = 0;                           ///< grid + height map + tag table
  double extruded_mm3 = 0;
};

struct DepositResult {
  VoxelGrid grid{0.05, Vec3::Zero(), Eigen::Vector3i::Zero()};
  double voxel_mm = 0.05;
  std::size_t voxels = 0;         ///< occupied voxels (grid.count())
  double volume_mm3 = 0;          ///< voxels * voxel^3
  double extruded_mm3 = 0;        ///< filament volume pushed by extruding moves
  double overlap_mm3 = 0;         ///< bead volume that fell on already occupied voxels
  double squeezed_mm3 = 0;        ///< of that, the volume squeezed into free voxels nearby
  Box3 bbox_mm;                   ///< of the occupied voxels (empty when none)
  std::size_t beads = 0;          ///< extruding moves laid
  std::size_t skipped_moves = 0;  ///< extruding moves with no XY length or no room (lay nothing)
  double unsupported_mm = 0;      ///< total length of unsupported bead
  std::vector<UnsupportedStretch> unsupported;  ///< every stretch, in G-code order
  /// extrusion_into_air_bridge / extrusion_into_air_cantilever, one per layer and kind.
  std::vector<Finding> findings;
  std::size_t memory_bytes = 0;  ///< grid + working memory
};

/// Size and memory of the deposit of `moves` (no allocation beyond a block bitmap).
[[nodiscard]] Result<DepositEstimate> estimate_deposit(std::span<const Move> moves,
                                                       const PrinterProfile& profile,
                                                       const DepositSettings& settings);

/// Deposits every extruding move. Errors: bad settings; estimated memory over
/// settings.max_memory_bytes (the message gives the estimate and a voxel size that fits).
[[nodiscard]] Result<DepositResult> deposit_moves(std::span<const Move> moves,
                                                  const PrinterProfile& profile,
                                                  const DepositSettings& settings);

/// Streaming deposit: moves are fed one by one (e.g. from the G-code interpreter's move
/// sink) into a grid whose extent is known beforehand (e.g. from a first pass, or the
/// build volume). Beads outside the extent are clipped.
class DepositBuilder {
 public:
  /// `extent_mm` bounds the nozzle tips of the extruding moves; `extruded_mm3_hint` (0 when
  /// unknown) sizes the memory estimate.
  [[nodiscard]] static Result<DepositBuilder> create(const Box3& extent_mm,
                                                     const PrinterProfile& profile,
                                                     const DepositSettings& settings,
                                                     double extruded_mm3_hint = 0);
  DepositBuilder(DepositBuilder&&) noexcept;
  DepositBuilder& operator=(DepositBuilder&&) noexcept;
  ~DepositBuilder();

  void add(const Move& move);
  /// Lays the last pending bead and returns the deposit; the builder is empty afterwards.
  [[nodiscard]] DepositResult finish();

 private:
  struct State;
  explicit DepositBuilder(std::unique_ptr<State> state);
  friend struct detail::DepositRun;  // deposit_moves (src/deposit/)
  std::unique_ptr<State> state_;
};

/// Bead width of the stadium model: w = area / h + (1 - pi/4) h.
[[nodiscard]] double stadium_width_mm(double area_mm2, double height_mm);

/// An occupied voxel with at least one face on the outside air.
struct SurfaceVoxel {
  VoxelKey key;
  /// Faces on the outside air: bit 0 -x, 1 +x, 2 -y, 3 +y, 4 -z, 5 +z.
  std::uint8_t exposed_faces = 0;
};
/// The deposit's outer surface: occupied voxels with a face on air connected to the grid's
/// border (space beyond the grid is air), the surface `verify` measures
/// (extract_outer_surface with DeviationSettings' seal and groove depth: pinholes between
/// beads do not expose enclosed cavities such as the cells of sparse infill, the grooves
/// between layers stay). Skirt, support, wipe tower and purge voxels are not part of it.
/// Fixed order (by 8^3 block and 4^3 cell, as DepositSurface::faces).
[[nodiscard]] std::vector<SurfaceVoxel> outer_surface(const VoxelGrid& grid);

/// The `deposit` object of the simulate JSON report (compact JSON text):
/// {"voxel_mm", "voxels", "volume_mm3", "extruded_mm3", "overlap_mm3",
///  "bbox_mm": {"min": [x,y,z], "max": [x,y,z]} (null when empty), "beads",
///  "unsupported_mm", "memory_bytes", "unsupported_stretches": {"bridge", "cantilever"}}.
[[nodiscard]] std::string deposit_json(const DepositResult& deposit);

/// How .ot files colour voxels.
enum class VoxelColoring { layer, feature };

/// Writes an OctoMap file: `.bt` (binary occupancy OcTree) or `.ot` (ColorOcTree coloured by
/// layer or feature), chosen by the extension. Readable by octovis and OctoMap's API.
[[nodiscard]] Status write_octomap(const VoxelGrid& grid, const std::filesystem::path& path,
                                   VoxelColoring coloring = VoxelColoring::layer);

/// Reads back an OctoMap .bt/.ot file and counts its occupied voxels at full resolution
/// (pruned nodes count as all the voxels they stand for). For tests and tools.
[[nodiscard]] Result<std::size_t> count_octomap_voxels(const std::filesystem::path& path);

/// Writes the outer surface voxels as a binary little-endian PLY point cloud with
/// properties x y z (float, voxel centres, mm), red green blue (by layer), layer (int),
/// feature (uchar, Feature value) and line (uint, G-code line).
[[nodiscard]] Status write_deposit_ply(const VoxelGrid& grid, const std::filesystem::path& path);

}  // namespace printtwin
