#pragma once
// Private to src/report/ (and verify_to_folder in src/verify/, which traces the heatmaps'
// views while the deposit runs): the two halves of a heatmap render and the traced views
// that reports of the same placed mesh share.
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "printtwin/report.hpp"

namespace printtwin {

/// The half of a heatmap render that depends only on the mesh and the view: the camera fitted
/// to the mesh and, per pixel (rows top to bottom), the ray hit and its lighting. Every
/// deviation result on the same placed mesh colours the same traced view.
struct TracedView {
  static constexpr std::uint32_t kNoHit = 0xffffffffu;
  ViewSpec view;
  Camera camera;
  double near_offset_mm = 0;            ///< rays start this far before the camera centre
  std::vector<std::uint32_t> triangle;  ///< hit triangle per pixel; kNoHit: background
  std::vector<float> depth_mm;          ///< hit distance from the ray origin
  std::vector<Vec3> normal;             ///< unit geometric normal of the hit triangle
  std::vector<double> shade;            ///< two Lambert lights times the outline darkening
  std::size_t hit_pixels = 0;
  /// Origin of the ray through pixel (x, y).
  [[nodiscard]] Vec3 pixel_origin(int x, int y) const;
};

/// Fits the camera to `mesh` and rasterises it: per pixel centre, the nearest triangle along
/// the view direction (what a ray from the pixel would hit first; equal depths: the lowest
/// triangle index), its depth and unit normal.
[[nodiscard]] TracedView trace_heatmap_view(const Mesh& mesh, const ViewSpec& view);

/// Colours a traced view of `mesh` (the mesh it was traced from) by the deviation field.
[[nodiscard]] HeatmapView shade_heatmap(const TracedView& traced, const Mesh& mesh,
                                        const SurfaceDeviationField& field,
                                        const DeviationColorScale& scale);

/// The traced views of one placed mesh, for reports of several deviation results on it
/// (compare's variants at the same placement, ReportFolderWriter) or traced before the
/// deviation is known (verify_to_folder). A report renders byte for byte the same with or
/// without it.
struct HeatmapCache {
  Mesh mesh;                      ///< the placed mesh the views were traced from
  std::vector<TracedView> views;  ///< one per ViewSpec, same order
  /// True when the cache was traced from exactly `placed_mesh` (every coordinate) and `views`.
  [[nodiscard]] bool fits(const Mesh& placed_mesh, std::span<const ViewSpec> views) const;
};

/// Traces `views` of `placed_mesh` (side by side; errors: the mesh has no triangles).
[[nodiscard]] Result<HeatmapCache> build_heatmap_cache(const Mesh& placed_mesh,
                                                       std::span<const ViewSpec> views);

/// Projects regions into a traced view and tests the visibility of their worst points
/// against its depth buffer (hidden when the surface at the point's pixel is clearly in
/// front of it; a point outside the image counts as visible).
[[nodiscard]] std::vector<RegionMarker> mark_regions(const TracedView& traced,
                                                     std::span<const DeviationRegion> regions);

}  // namespace printtwin

namespace printtwin::detail {

/// render_report_assets, build_report_files and write_report_folder with traced views to
/// reuse (not owned; null: none). Used when they fit the report's placed mesh and views;
/// otherwise the report traces its own. The bytes are the same either way.
[[nodiscard]] Result<ReportAssets> render_report_assets(const VerifyReport& report,
                                                        const ReportOptions& options,
                                                        const HeatmapCache* cache);
[[nodiscard]] Result<std::vector<ReportFile>> build_report_files(const VerifyReport& report,
                                                                 const ReportOptions& options,
                                                                 const HeatmapCache* cache);
[[nodiscard]] Status write_report_folder(const VerifyReport& report,
                                         const std::filesystem::path& out_dir,
                                         const ReportOptions& options, const HeatmapCache* cache);

}  // namespace printtwin::detail
