// The report folder: every file built in memory, written into a hidden staging folder beside
// the target, then swapped into place with renames. A killed or failed run leaves at most a
// hidden ".<name>.staging-<pid>-*" folder, never a report that looks complete; the next run
// for the same report removes such leftovers once their process is gone.
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <chrono>
#include <cstring>
#include <optional>
#include <random>
#include <string_view>
#include <system_error>
#include <vector>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_group.h>

#include "printtwin/io.hpp"
#include "report/report_internal.hpp"

namespace printtwin {

namespace fs = std::filesystem;

bool HeatmapCache::fits(const Mesh& placed_mesh, std::span<const ViewSpec> specs) const {
  if (views.size() != specs.size()) return false;
  for (std::size_t i = 0; i < specs.size(); ++i)
    if (!(views[i].view == specs[i])) return false;
  return mesh == placed_mesh;
}

Result<HeatmapCache> build_heatmap_cache(const Mesh& placed_mesh, std::span<const ViewSpec> views) {
  if (placed_mesh.triangles.empty())
    return bad_input("cannot render the heatmaps: the mesh has no triangles");
  HeatmapCache cache{placed_mesh, std::vector<TracedView>(views.size())};
  tbb::parallel_for(std::size_t{0}, views.size(), [&](std::size_t i) {
    cache.views[i] = trace_heatmap_view(cache.mesh, views[i]);
  });
  return cache;
}

Result<ReportAssets> render_report_assets(const VerifyReport& report,
                                          const ReportOptions& options) {
  return detail::render_report_assets(report, options, nullptr);
}

Result<ReportAssets> detail::render_report_assets(const VerifyReport& report,
                                                  const ReportOptions& options,
                                                  const HeatmapCache* cache) {
  // The caller's traced views when they belong to this mesh, else this report's own.
  std::optional<HeatmapCache> own;
  if (cache == nullptr || !cache->fits(report.placed_mesh, options.views)) {
    auto built = build_heatmap_cache(report.placed_mesh, options.views);
    if (!built) return built.error();
    own = std::move(*built);
    cache = &*own;
  }
  ReportAssets assets;
  assets.scale = make_color_scale(report.deviation);
  SurfaceDeviationField field;
  field.sample_positions_mm = report.deviation.mesh_samples.positions_mm;
  field.sample_distances_mm = report.deviation.mesh_samples.distances_mm;
  field.vertex_deviation_mm = report.deviation.vertex_deviation_mm;
  field.sample_spacing_mm = report.settings.mesh_sample_spacing_mm > 0
                                ? report.settings.mesh_sample_spacing_mm
                                : report.settings.voxel_mm;
  // The views side by side (each also parallel inside; PNG encoding is one thread per
  // image), and beside them the layer viewer's data.
  const std::size_t n = cache->views.size();
  std::vector<std::optional<HeatmapView>> views(n);
  std::vector<std::optional<Result<std::string>>> pngs(n);
  tbb::parallel_invoke(
      [&] {
        tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
          HeatmapView hv = shade_heatmap(cache->views[i], cache->mesh, field, assets.scale);
          hv.markers = mark_regions(cache->views[i], report.deviation.regions);
          pngs[i].emplace(encode_png(hv.image));
          views[i].emplace(std::move(hv));
        });
      },
      [&] { assets.viewer_data = detail::viewer_json(report, assets.scale, options); });
  for (std::size_t i = 0; i < n; ++i) {
    if (!*pngs[i]) return pngs[i]->error();
    assets.view_png.push_back(std::move(*pngs[i]).value());
    assets.views.push_back(std::move(*views[i]));
  }
  return assets;
}

Result<std::vector<ReportFile>> build_report_files(const VerifyReport& report,
                                                   const ReportOptions& options) {
  return detail::build_report_files(report, options, nullptr);
}

Result<std::vector<ReportFile>> detail::build_report_files(const VerifyReport& report,
                                                           const ReportOptions& options,
                                                           const HeatmapCache* cache) {
  auto assets = render_report_assets(report, options, cache);
  if (!assets) return assets.error();
  std::vector<ReportFile> files;
  files.push_back({"report.html", report_html(report, *assets, options)});
  files.push_back({"junit.xml", report_junit_xml(report, options)});
  files.push_back({"summary.md", report_summary_markdown(report, options)});
  if (options.write_png_files)
    for (std::size_t i = 0; i < assets->views.size(); ++i)
      files.push_back({"heatmap_" + assets->views[i].view.name + ".png", assets->view_png[i]});
  return files;
}

namespace {

constexpr std::string_view kStaging = ".staging-";

/// The process id in a staging folder's tag ("<pid>-<random>"), 0 when there is none.
long staging_owner(std::string_view tag) {
  const auto dash = tag.find('-');
  long pid = 0;
  const auto [ptr, ec] =
      std::from_chars(tag.data(), tag.data() + (dash == std::string_view::npos ? 0 : dash), pid);
  return ec == std::errc() && ptr == tag.data() + dash ? pid : 0;
}

/// Removes the staging folders of earlier runs for this report that were killed before they
/// finished (their process is gone). A staging folder of a live process (another run
/// writing the same report right now) is left alone; one without a process id in its name
/// is removed when it is older than an hour.
void remove_stale_staging(const fs::path& parent, const std::string& name) {
  const std::string prefix = "." + name + std::string(kStaging);
  std::error_code ec;
  std::vector<fs::path> stale;
  for (fs::directory_iterator it(parent, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string entry = it->path().filename().string();
    if (!entry.starts_with(prefix)) continue;
    const long pid = staging_owner(std::string_view(entry).substr(prefix.size()));
    bool dead = false;
    if (pid > 0) {
      dead = ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
    } else {
      std::error_code tec;
      const auto age = fs::file_time_type::clock::now() - fs::last_write_time(it->path(), tec);
      dead = !tec && age > std::chrono::hours(1);
    }
    if (dead) stale.push_back(it->path());
  }
  for (const auto& p : stale) fs::remove_all(p, ec);
}

/// Moves the finished `staging` folder to `target` in one step, whether or not a report is
/// there already, with no moment at which `target` is missing or partly written. On Linux:
/// renameat2 with RENAME_NOREPLACE when there is no report yet, else RENAME_EXCHANGE (the old
/// report then sits in `staging`, and is removed). Two runs finishing at the same time each
/// put a whole report in place; the last one stays. Elsewhere: rename aside, then in.
Status swap_into_place(const fs::path& staging, const fs::path& target) {
  std::error_code ec;
#if defined(__linux__) && defined(RENAME_EXCHANGE)
  for (int attempt = 0; attempt < 100; ++attempt) {
    if (::renameat2(AT_FDCWD, staging.c_str(), AT_FDCWD, target.c_str(), RENAME_NOREPLACE) == 0)
      return Ok{};
    if (errno != EEXIST) break;
    if (::renameat2(AT_FDCWD, staging.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) == 0) {
      fs::remove_all(staging, ec);  // the report that was replaced
      return Ok{};
    }
    if (errno != ENOENT) break;  // the target went away in between: try again
  }
  if (errno != EINVAL && errno != ENOSYS)  // else: a file system without renameat2's flags
    return bad_input(
        std::string("cannot move the finished report into place: ") + std::strerror(errno),
        target.string());
#endif
  const fs::path old = staging.string() + ".old";
  const bool had_old = fs::exists(target, ec);
  if (had_old) {
    fs::rename(target, old, ec);
    if (ec)
      return bad_input("cannot replace the existing report: " + ec.message(), target.string());
  }
  fs::rename(staging, target, ec);
  if (ec) {
    const std::string msg = ec.message();
    std::error_code ignored;
    if (had_old) fs::rename(old, target, ignored);
    return bad_input("cannot move the finished report into place: " + msg, target.string());
  }
  if (had_old) fs::remove_all(old, ec);
  return Ok{};
}

}  // namespace

Status write_report_folder(const VerifyReport& report, const fs::path& out_dir,
                           const ReportOptions& options) {
  return detail::write_report_folder(report, out_dir, options, nullptr);
}

Status detail::write_report_folder(const VerifyReport& report, const fs::path& out_dir,
                                   const ReportOptions& options, const HeatmapCache* cache) {
  const fs::path target = out_dir.has_filename() ? out_dir : out_dir.parent_path();
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string name = target.filename().string();
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec)
    return bad_input("cannot create the report's parent folder: " + ec.message(), parent.string());
  if (fs::exists(target, ec) && !fs::is_directory(target, ec))
    return bad_input("exists and is not a folder; expected a report folder", target.string());
  remove_stale_staging(parent, name);
  // The staging folder's name carries this process's id, so that a later run can tell a
  // killed run's leftovers from a run still in progress.
  std::random_device rd;
  const std::string tag = std::to_string(::getpid()) + "-" + std::to_string(rd() % 100000000);
  const fs::path staging = parent / ("." + name + std::string(kStaging) + tag);
  auto fail = [&](Error e) -> Status {
    fs::remove_all(staging, ec);
    return e;
  };
  fs::create_directories(staging, ec);
  if (ec)
    return fail(bad_input("cannot create a staging folder: " + ec.message(), staging.string()));
  // The report's own files and the caller's extra outputs (report.json, deviation.ply) are
  // made side by side; a failure of the former is reported first.
  std::optional<Result<std::vector<ReportFile>>> files;
  Status extra = Ok{};
  tbb::task_group both;
  both.run([&] { files.emplace(build_report_files(report, options, cache)); });
  if (options.extra_outputs) both.run([&] { extra = options.extra_outputs(staging); });
  both.wait();
  if (!*files) return fail(files->error());
  if (!extra) return fail(extra.error());
  for (const auto& f : **files) {
    auto st = write_file_atomic(staging / f.name, f.content);
    if (!st) return fail(st.error());
  }
  if (auto st = swap_into_place(staging, target); !st) return fail(st.error());
  return Ok{};
}

struct ReportFolderWriter::State {
  std::optional<HeatmapCache> heatmaps;  ///< the views of the last report's placed mesh
};

ReportFolderWriter::ReportFolderWriter() : state_(std::make_unique<State>()) {}
ReportFolderWriter::ReportFolderWriter(ReportFolderWriter&&) noexcept = default;
ReportFolderWriter& ReportFolderWriter::operator=(ReportFolderWriter&&) noexcept = default;
ReportFolderWriter::~ReportFolderWriter() = default;

Status ReportFolderWriter::write(const VerifyReport& report, const fs::path& out_dir,
                                 const ReportOptions& options) {
  auto& heatmaps = state_->heatmaps;
  if (!heatmaps || !heatmaps->fits(report.placed_mesh, options.views)) {
    heatmaps.reset();
    auto built = build_heatmap_cache(report.placed_mesh, options.views);
    if (!built) return built.error();
    heatmaps.emplace(std::move(*built));
  }
  return detail::write_report_folder(report, out_dir, options, &*heatmaps);
}

}  // namespace printtwin
