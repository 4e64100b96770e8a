#pragma once
// report: what people and CI systems read after `printtwin verify`.
//
// From one VerifyReport value (verify.hpp) this stage writes, into one output folder:
//   report.html   self-contained page (inline CSS, JS, PNG images as data: URIs; no network):
//                 verdict and gates, key numbers, heatmaps of the part coloured by signed
//                 deviation from several views (orthographic, rasterised),
//                 histogram, deviation per layer, a layer viewer, regions, findings, inputs
//                 with SHA-256, settings and the printtwin version;
//   junit.xml     one test case per gate and per error finding (GitHub, GitLab, Jenkins);
//   summary.md    a short Markdown verdict and table for CI job summaries;
//   heatmap_<view>.png  the heatmap images as files;
//   report.json, deviation.ply (write_verify_outputs, verify.hpp) and whatever
//                 `ReportOptions::extra_outputs` adds (e.g. deposit.ot).
// The folder is written under a temporary name and renamed into place, so a failed or
// killed run never leaves a report that looks complete (docs/reports.md).
//
// Determinism: every byte depends only on the VerifyReport and the ReportOptions. The one
// run-dependent value, the generation time, is `ReportOptions::generated_utc` (set by the
// caller; empty means "not stamped").
//
// Colour convention everywhere (images, charts, layer viewer): deficit (d < -tolerance)
// blue, within tolerance green, excess (d > +tolerance) red; darker = further out.
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "printtwin/deviation_types.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"
#include "printtwin/verify.hpp"

namespace printtwin {

/// 8-bit RGBA image, rows top to bottom, 4 bytes per pixel, no padding.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  ///< width * height * 4 bytes
  bool operator==(const Image&) const = default;
};

/// PNG bytes of an image (libpng, 8-bit RGBA). Deterministic for the same pixels.
[[nodiscard]] Result<std::string> encode_png(const Image& image);
/// Decodes PNG bytes of any colour type to RGBA (for tests and tools).
[[nodiscard]] Result<Image> decode_png(std::string_view png_bytes);

/// Maps signed deviation (mm) to colour. |d| <= tolerance is green; beyond, the colour runs
/// from light to dark blue (deficit) or red (excess) and saturates at +-range_mm.
struct DeviationColorScale {
  double tolerance_mm = 0.2;
  double range_mm = 1.0;  ///< >= tolerance_mm; values beyond are clamped to the end colours
  [[nodiscard]] std::array<std::uint8_t, 3> color(double d_mm) const;
};

/// Scale for a deviation result: tolerance from it, range = the largest |d| of the vertex
/// and mesh-sample deviations rounded up to a "nice" number, clamped to
/// [2 * tolerance, 10 * tolerance].
[[nodiscard]] DeviationColorScale make_color_scale(const DeviationResult& deviation);

/// An orthographic view: the camera looks along `direction` (towards the part) with `up`
/// pointing to the top of the image.
struct ViewSpec {
  std::string name;   ///< "iso", "front", "right", "top" ... (file name heatmap_<name>.png)
  std::string label;  ///< caption, e.g. "Isometric"
  Vec3 direction = Vec3(0, 1, 0);
  Vec3 up = Vec3(0, 0, 1);
  int width_px = 320;
  int height_px = 320;  ///< upper bound; the image is cropped to the part's aspect
  bool operator==(const ViewSpec&) const = default;
};

/// Isometric (large) plus front (-Y looking +Y), right (+X looking -X) and top views.
[[nodiscard]] std::vector<ViewSpec> default_views();

/// Pixel <-> machine-frame mapping of an orthographic render.
struct Camera {
  Vec3 center_mm = Vec3::Zero();  ///< world point at the image centre
  Vec3 right = Vec3(1, 0, 0);     ///< unit, image +x
  Vec3 up = Vec3(0, 0, 1);        ///< unit, image -y (rows go down)
  Vec3 forward = Vec3(0, 1, 0);   ///< unit, viewing direction
  double mm_per_px = 0.1;
  int width_px = 0, height_px = 0;
  /// Pixel coordinates (x right, y down; pixel centres at +0.5) of a world point.
  [[nodiscard]] Vec2 project(const Vec3& p_mm) const;
};

/// Where a deviation region appears in a view (for the numbered pins over the images).
struct RegionMarker {
  Vec2 worst_px = Vec2::Zero();  ///< the region's worst point, pixels
  Vec2 bbox_min_px = Vec2::Zero(), bbox_max_px = Vec2::Zero();  ///< projected bounding box
  bool visible = true;  ///< false when the part hides the worst point in this view
};

/// A rendered heatmap view.
struct HeatmapView {
  ViewSpec view;
  Camera camera;
  Image image;                        ///< transparent background
  std::size_t hit_pixels = 0;         ///< pixels that show the part
  std::vector<RegionMarker> markers;  ///< one per DeviationResult::regions entry, same order
};

/// Per-point deviation on the mesh surface used to colour the heatmap: mesh-surface samples
/// (mesh -> deposit direction) where they are dense enough, per-vertex deviation
/// (barycentric interpolation) elsewhere.
struct SurfaceDeviationField {
  std::span<const Vec3> sample_positions_mm;    ///< mesh-surface samples (may be empty)
  std::span<const double> sample_distances_mm;  ///< their signed deviation (same size)
  std::span<const double> vertex_deviation_mm;  ///< per mesh vertex (may be empty)
  double sample_spacing_mm = 0;  ///< typical sample spacing (0: estimated from the area)
};

/// Renders one orthographic view of `mesh` (the nearest triangle under each pixel centre),
/// colours it by the deviation field and shades it with two Lambert lights. Back faces (open
/// meshes) are grey. Deterministic. `markers` is left empty.
[[nodiscard]] HeatmapView render_heatmap(const Mesh& mesh, const SurfaceDeviationField& field,
                                         const DeviationColorScale& scale, const ViewSpec& view);

/// Cuts `mesh` at each height of `z_mm` (sorted or not) and chains the cuts into polylines
/// (machine frame XY, mm; closed loops repeat their first point), simplified with
/// Douglas-Peucker at `simplify_mm`. One pass over the triangles. Result[i] belongs to z_mm[i].
[[nodiscard]] std::vector<std::vector<std::vector<Vec2>>> cut_mesh(const Mesh& mesh,
                                                                   std::span<const double> z_mm,
                                                                   double simplify_mm);

/// Knobs of the report writer. Defaults keep report.html of a ~200k-triangle part well under
/// 5 MB and its generation under a second on one core.
struct ReportOptions {
  /// Generation time shown in the reports (e.g. "2026-11-21T10:20:00Z"); the only
  /// run-dependent input. Empty: not stamped.
  std::string generated_utc;
  std::vector<ViewSpec> views = default_views();
  /// Deposit-surface points embedded for the layer viewer, over all layers.
  std::size_t max_viewer_points = 160000;
  /// Layers offered by the layer viewer (evenly subsampled beyond this).
  int max_viewer_layers = 400;
  /// Douglas-Peucker tolerance of the mesh cross-sections in the layer viewer.
  double section_simplify_mm = 0.02;
  /// Histogram bins over [-range, +range] of the colour scale.
  int histogram_bins = 60;
  /// Write heatmap_<view>.png files beside report.html.
  bool write_png_files = true;
  /// Called with the staging folder before it is renamed into place, to add more files
  /// (e.g. deposit.ot). An error aborts the report and leaves no folder behind.
  std::function<Status(const std::filesystem::path& staging_dir)> extra_outputs;
  /// The as-printed mesh written beside the report (--deposit-mesh): link relative to
  /// report.html (empty: none) and one line about it (plain text).
  std::string deposit_mesh_href;
  std::string deposit_mesh_text;
};

/// JUnit XML (testsuites/testsuite/testcase, failures with messages): one case per gate
/// and per error finding. Deterministic.
[[nodiscard]] std::string report_junit_xml(const VerifyReport& report,
                                           const ReportOptions& options = {});

/// Markdown verdict + gate table + key numbers + largest regions, for CI job summaries.
[[nodiscard]] std::string report_summary_markdown(const VerifyReport& report,
                                                  const ReportOptions& options = {});

/// Everything report.html embeds, computed once (renders, cross-sections, charts).
struct ReportAssets {
  DeviationColorScale scale;
  std::vector<HeatmapView> views;
  std::vector<std::string> view_png;  ///< PNG bytes of each view, same order
  /// The layer viewer's data (JSON) for report.html, made beside the views; when empty,
  /// report_html makes it.
  std::string viewer_data;
};

/// Renders the heatmap views of `report.placed_mesh` (errors: the mesh cannot be queried).
[[nodiscard]] Result<ReportAssets> render_report_assets(const VerifyReport& report,
                                                        const ReportOptions& options = {});

/// The self-contained report.html text.
[[nodiscard]] std::string report_html(const VerifyReport& report, const ReportAssets& assets,
                                      const ReportOptions& options = {});

/// One output file of the report folder.
struct ReportFile {
  std::string name;     ///< file name inside the folder
  std::string content;  ///< bytes
};

/// report.html, junit.xml, summary.md and the heatmap PNGs, in memory.
[[nodiscard]] Result<std::vector<ReportFile>> build_report_files(const VerifyReport& report,
                                                                 const ReportOptions& options = {});

/// Writes the whole report folder `out_dir`: builds every file in a sibling staging folder
/// (each file via write_file_atomic), then swaps the staging folder into place (an existing
/// `out_dir` is replaced only after the new report is complete). Errors: unwritable folder
/// (bad_input), mesh that cannot be rendered (internal).
[[nodiscard]] Status write_report_folder(const VerifyReport& report,
                                         const std::filesystem::path& out_dir,
                                         const ReportOptions& options = {});

/// Writes the report folders of several reports of one part (compare's variants), each the
/// same bytes as write_report_folder would write. Reports whose placed mesh is the same as
/// the previous one's share the work that depends only on the mesh (the heatmaps' rays), so
/// a series of variants at one placement is faster. One writer per thread.
class ReportFolderWriter {
 public:
  ReportFolderWriter();
  ReportFolderWriter(ReportFolderWriter&&) noexcept;
  ReportFolderWriter& operator=(ReportFolderWriter&&) noexcept;
  ~ReportFolderWriter();
  /// write_report_folder(report, out_dir, options).
  [[nodiscard]] Status write(const VerifyReport& report, const std::filesystem::path& out_dir,
                             const ReportOptions& options = {});

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// verify() and the whole report folder in one call: runs the pipeline of `options`, then
/// writes `out_dir` as write_report_folder does, with report.json and deviation.ply
/// (write_verify_outputs) beside the files of `report_options.extra_outputs`. The same bytes
/// as the calls one after the other; faster, since the report's work that needs only the
/// placed mesh runs while the deposit is still being laid. Errors: those of verify (no
/// folder is written) and of write_report_folder. `derived_outputs`, when given, runs on the
/// finished report before the folder is written: it writes files derived from the report
/// (e.g. the as-printed mesh, --deposit-mesh) and sets their links in the options; its error
/// aborts the report.
using DerivedOutputs = std::function<Status(VerifyReport& report, ReportOptions& options)>;
[[nodiscard]] Result<VerifyReport> verify_to_folder(const VerifyOptions& options,
                                                    const std::filesystem::path& out_dir,
                                                    const ReportOptions& report_options = {},
                                                    const DerivedOutputs& derived_outputs = {});

/// Current UTC time as "YYYY-MM-DDTHH:MM:SSZ", or the time of $SOURCE_DATE_EPOCH when set
/// (reproducible builds convention), for `ReportOptions::generated_utc`.
[[nodiscard]] std::string report_timestamp_utc();

}  // namespace printtwin
