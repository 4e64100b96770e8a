#pragma once
// Value types of the deviation stage (deviation.hpp computes them, report.hpp writes them).
// Signed distances: positive = material outside the designed part (excess), negative =
// inside it / missing (deficit). Millimetres.
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "printtwin/geometry.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin {

/// Statistics of one direction of signed distances.
struct DeviationStats {
  std::size_t samples = 0;
  double min_mm = 0, max_mm = 0;  ///< signed extremes
  double mean_mm = 0;             ///< signed mean
  double mean_abs_mm = 0;         ///< mean of |d|
  double rms_mm = 0, std_mm = 0;
  double p50_abs_mm = 0, p95_abs_mm = 0, p99_abs_mm = 0;  ///< percentiles of |d|
  double within_tolerance_pct = 100;                      ///< share of |d| <= tolerance
  double hausdorff_mm = 0;                                ///< max |d|
};

/// One measured point.
struct DeviationSample {
  Vec3 position_mm = Vec3::Zero();  ///< where the sample sits (deposit or mesh surface)
  double distance_mm = 0;           ///< signed distance
  std::int32_t layer = -1;          ///< layer of the nearest deposit voxel
  std::uint32_t line = 0;           ///< G-code line of the nearest deposit voxel (0: none)
  /// Mesh triangle: of the closest point (deposit -> mesh) or the one the sample lies on
  /// (mesh -> deposit); UINT32_MAX when unknown.
  std::uint32_t triangle = 0xFFFFFFFFu;
};

/// The samples of one direction as columns: row i of every column is sample i. The stage
/// computes its figures in these arrays and keeps them as they are (no per-sample copy:
/// 2.9 M deposit samples would be 140 MB more). Rows read as DeviationSample values.
struct DeviationSamples {
  std::vector<Vec3> positions_mm;        ///< DeviationSample::position_mm
  std::vector<double> distances_mm;      ///< DeviationSample::distance_mm
  std::vector<VoxelTag> tags;            ///< nearest deposit voxel's tag (layer, line)
  std::vector<std::uint32_t> triangles;  ///< DeviationSample::triangle

  [[nodiscard]] std::size_t size() const { return distances_mm.size(); }
  [[nodiscard]] bool empty() const { return distances_mm.empty(); }
  [[nodiscard]] DeviationSample operator[](std::size_t i) const {
    return {positions_mm[i], distances_mm[i], tags[i].layer, tags[i].line, triangles[i]};
  }
  void push_back(const DeviationSample& s) {
    positions_mm.push_back(s.position_mm);
    distances_mm.push_back(s.distance_mm);
    tags.push_back(VoxelTag{s.line, s.layer, Feature::unknown});
    triangles.push_back(s.triangle);
  }
  void clear() { *this = {}; }

  /// Iterates the rows as DeviationSample values.
  class const_iterator {
   public:
    using iterator_category = std::input_iterator_tag;
    using value_type = DeviationSample;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = DeviationSample;
    const_iterator(const DeviationSamples* set, std::size_t i) : set_(set), i_(i) {}
    DeviationSample operator*() const { return (*set_)[i_]; }
    const_iterator& operator++() { return ++i_, *this; }
    const_iterator operator++(int) {
      const_iterator old = *this;
      ++i_;
      return old;
    }
    bool operator==(const const_iterator& o) const { return i_ == o.i_; }

   private:
    const DeviationSamples* set_;
    std::size_t i_;
  };
  [[nodiscard]] const_iterator begin() const { return {this, 0}; }
  [[nodiscard]] const_iterator end() const { return {this, size()}; }
};

struct LayerDeviation {
  int layer = 0;
  double z_mm = 0;
  DeviationStats deposit_to_mesh;
  DeviationStats mesh_to_deposit;
  /// Layer lines: over this layer's deposit surface on walls (points whose closest design
  /// triangle is within 15 degrees of vertical, farther than 0.3 mm from the design's sharp
  /// edges), area-weighted: the RMS distance to the design and the roughness Rq (RMS about
  /// the layer's own mean). 0 where the layer has no wall.
  double wall_rms_mm = 0, wall_rq_mm = 0;
};

enum class RegionKind { missing, excess };

/// A cluster of out-of-tolerance samples.
struct DeviationRegion {
  RegionKind kind = RegionKind::missing;
  Box3 bbox_mm;
  int layer_min = -1, layer_max = -1;
  double area_mm2 = 0;  ///< surface area the samples stand for
  double worst_mm = 0;  ///< signed worst distance
  Vec3 worst_position_mm = Vec3::Zero();
  std::size_t samples = 0;
  std::vector<long> gcode_lines;  ///< lines that laid the nearest deposit (sorted, unique, capped)
};

struct DepositSurface;

struct DeviationResult {
  double tolerance_mm = 0.2;
  DeviationStats deposit_to_mesh;
  DeviationStats mesh_to_deposit;
  DeviationSamples
      deposit_samples;  ///< deposit outer surface -> mesh (DeviationSettings::keep_samples)
  DeviationSamples mesh_samples;  ///< mesh surface -> deposit (DeviationSettings::keep_samples)
  std::vector<LayerDeviation> per_layer;
  std::vector<DeviationRegion> regions;  ///< largest first
  /// Gate figures (>= 0): the largest excess (deposit outside the design) and the largest
  /// deficit (design surface the deposit misses), ignoring out-of-tolerance clusters smaller
  /// than the minimum region area (voxel noise); those are counted in noise_*.
  double max_excess_mm = 0;
  double max_deficit_mm = 0;
  std::size_t noise_regions = 0;
  double noise_area_mm2 = 0;
  double mesh_volume_mm3 = 0;
  double deposit_volume_mm3 = 0;   ///< part voxels in the analysed region
  std::size_t surface_faces = 0;   ///< exposed faces of the deposit's outer surface
  std::size_t surface_voxels = 0;  ///< voxels that carry them
  /// Layer lines over the whole part's walls (LayerDeviation::wall_rms_mm, wall_rq_mm): RMS
  /// to the design and Rq (the root of the area-weighted mean of each layer's variance).
  double wall_rms_mm = 0, wall_rq_mm = 0;
  double wall_area_mm2 = 0;     ///< deposit surface on walls
  double wall_mesh_rms_mm = 0;  ///< mesh -> deposit RMS of the mesh samples on those walls
  Vec3 registration_offset_mm = Vec3::Zero();  ///< added to the mesh to reach the G-code frame
  std::string registration_method;             ///< "auto" or "--place"
  /// Signed deviation per mesh vertex (for the deviation PLY and heatmaps).
  std::vector<double> vertex_deviation_mm;
  /// The deposit's filled volume as the outer-surface step found it (region, filled blocks
  /// and masks only; no faces), when DeviationSettings::keep_filled_volume: --deposit-mesh
  /// builds the as-printed mesh on it instead of extracting it again.
  std::shared_ptr<const DepositSurface> filled_volume;
};

}  // namespace printtwin
