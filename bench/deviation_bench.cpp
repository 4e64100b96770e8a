// Deviation stage benchmark and the helper of bench/c2m_compare.sh.
//
//   deviation_bench [benchmark flags]      the deviation stage (compute_deviation) on the
//                                          deposit of $PRINTTWIN_BENCH_GCODE against
//                                          $PRINTTWIN_BENCH_MESH (default: the 10 mm cube
//                                          sample) at $PRINTTWIN_BENCH_VOXEL (0.05) mm
//   deviation_bench --export MESH GCODE DIR [VOXEL]
//                                          runs verify, writes DIR/points.ply (deposit face
//                                          centres) and DIR/mesh.stl
//                                          (the mesh placed in the G-code frame)
//   deviation_bench --c2m POINTS.ply MESH.stl
//                                          whole-process distance of points to a mesh (the
//                                          counterpart of CloudCompare -C2M_DIST); prints
//                                          n, mean|d|, rms|d|, max|d|
//   deviation_bench --checksum             one compute_deviation on the benchmark data (as
//                                          above): a hash of every sample, vertex deviation,
//                                          region and statistic (bit patterns), so a change
//                                          that must not change the results can be checked
//                                          bit for bit, plus the CPU time of that call, of
//                                          the call repeated (least of 3: its memory reused,
//                                          no first touch of fresh pages) and of each phase;
//                                          $PRINTTWIN_PERF_CTL_FD: see perf_control
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <tuple>

#include <unistd.h>

#include "deviation/deposit_surface_internal.hpp"
#include "deviation/outer_surface.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/io.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/simulate.hpp"
#include "printtwin/verify.hpp"

namespace {

using namespace printtwin;

std::string env_or(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::string(v) : fallback;
}

class Collect final : public MoveSink {
 public:
  std::vector<Move> moves;
  void on_move(const Move& m) override { moves.push_back(m); }
};

struct Prepared {
  Mesh placed;
  DepositResult deposit;
  Box3 part;
  std::vector<SurfaceBead> beads;  ///< the beads verify measures the surface on
};

/// Simulates and deposits the benchmark's G-code once, places the mesh.
const Prepared& prepared() {
  static const Prepared p = [] {
    Prepared out;
    const std::string gcode =
        env_or("PRINTTWIN_BENCH_GCODE",
               std::string(PRINTTWIN_SOURCE_DIR) + "/samples/gcode/prusa_cube10.gcode");
    const std::string mesh_path = env_or("PRINTTWIN_BENCH_MESH", "");
    const double voxel = std::stod(env_or("PRINTTWIN_BENCH_VOXEL", "0.05"));
    auto profile = load_printer_profile("ender3");
    Collect c;
    std::ifstream in(gcode, std::ios::binary);
    auto sim = simulate_gcode(in, *profile, {}, &c);
    if (!sim) throw std::runtime_error(sim.error().describe());
    DepositSettings ds;
    ds.voxel_mm = voxel;
    auto dep = deposit_moves(c.moves, *profile, ds);
    if (!dep) throw std::runtime_error(dep.error().describe());
    Mesh mesh = make_box_mesh(Vec3(-5, -5, 0), Vec3(5, 5, 10));
    if (!mesh_path.empty()) {
      auto loaded = load_mesh(mesh_path);
      if (!loaded) throw std::runtime_error(loaded.error().describe());
      mesh = std::move(*loaded);
    }
    const PartExtent part = find_part_extent(c.moves);
    const Vec3 offset = registration_offset(mesh, part);
    out.placed = translated(std::move(mesh), offset);
    out.deposit = std::move(*dep);
    out.part = part.bbox_mm;
    out.beads = surface_beads(c.moves, *profile);
    return out;
  }();
  return p;
}

void BM_DeviationStage(benchmark::State& state) {
  const Prepared& p = prepared();
  DeviationSettings settings;
  settings.keep_samples = false;
  std::size_t faces = 0, samples = 0;
  for (auto _ : state) {
    auto r = compute_deviation(p.placed, p.deposit.grid, settings, p.part, p.beads);
    if (!r) state.SkipWithError(r.error().describe().c_str());
    faces = r->surface_faces;
    samples = r->mesh_to_deposit.samples;
    benchmark::DoNotOptimize(r->deposit_to_mesh.rms_mm);
  }
  state.counters["surface_faces"] = static_cast<double>(faces);
  state.counters["mesh_samples"] = static_cast<double>(samples);
  state.counters["triangles"] = static_cast<double>(p.placed.triangles.size());
}
BENCHMARK(BM_DeviationStage)->Unit(benchmark::kMillisecond)->Iterations(3)->MeasureProcessCPUTime();

/// The design side alone (what `compare` shares between variants): BVH, pseudo-normals,
/// surface samples.
void BM_DeviationTargetBuild(benchmark::State& state) {
  const Prepared& p = prepared();
  DeviationSettings settings;
  for (auto _ : state) {
    auto t = DeviationTarget::build(p.placed, settings, p.deposit.grid.voxel_mm());
    if (!t) state.SkipWithError(t.error().describe().c_str());
    benchmark::DoNotOptimize(t->samples().size());
  }
}
BENCHMARK(BM_DeviationTargetBuild)->Unit(benchmark::kMillisecond)->Iterations(3);

/// The deviation stage per deposit with the target prepared once (compare's variants).
void BM_DeviationStageReusedTarget(benchmark::State& state) {
  const Prepared& p = prepared();
  DeviationSettings settings;
  settings.keep_samples = false;
  auto target = DeviationTarget::build(p.placed, settings, p.deposit.grid.voxel_mm());
  if (!target) {
    state.SkipWithError(target.error().describe().c_str());
    return;
  }
  for (auto _ : state) {
    auto r = compute_deviation(*target, Vec3::Zero(), p.deposit.grid, settings, p.part, p.beads);
    if (!r) state.SkipWithError(r.error().describe().c_str());
    benchmark::DoNotOptimize(r->deposit_to_mesh.rms_mm);
  }
}
BENCHMARK(BM_DeviationStageReusedTarget)->Unit(benchmark::kMillisecond)->Iterations(3);

/// Process CPU time (all threads), seconds.
double cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// FNV-1a over the bytes of values.
struct Hash {
  std::uint64_t h = 1469598103934665603ULL;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 1099511628211ULL;
  }
  template <class T>
  void add(const T& v) {
    bytes(&v, sizeof v);
  }
  void add(const Vec3& v) {
    for (int a = 0; a < 3; ++a) add(v[a]);
  }
  void add(const DeviationStats& s) {
    for (const double x :
         {s.min_mm, s.max_mm, s.mean_mm, s.mean_abs_mm, s.rms_mm, s.std_mm, s.p50_abs_mm,
          s.p95_abs_mm, s.p99_abs_mm, s.within_tolerance_pct, s.hausdorff_mm})
      add(x);
    add(s.samples);
  }
  void add(const DeviationSamples& list) {
    for (const DeviationSample x : list) {
      add(x.position_mm);
      add(x.distance_mm);
      add(x.layer);
      add(x.line);
      add(x.triangle);
    }
  }
};

/// With $PRINTTWIN_PERF_CTL_FD (perf record --control fd:N -D -1), profiles only the
/// compute_deviation call.
void perf_control(const char* cmd) {
  const char* fd = std::getenv("PRINTTWIN_PERF_CTL_FD");
  if (fd == nullptr || *fd == '\0') return;
  const int n = std::atoi(fd);
  if (::write(n, cmd, std::strlen(cmd)) < 0) std::perror("perf control");
}

int checksum() {
  const Prepared& p = prepared();
  DeviationSettings settings;
  const double t0 = cpu_s();
  auto target = DeviationTarget::build(p.placed, settings, p.deposit.grid.voxel_mm());
  if (!target) return 3;
  const double t1 = cpu_s();
  perf_control("enable\n");
  auto r = compute_deviation(*target, Vec3::Zero(), p.deposit.grid, settings, p.part, p.beads);
  if (!r) return 3;
  perf_control("disable\n");
  const double t2 = cpu_s();
  Hash h;
  h.add(r->deposit_to_mesh);
  h.add(r->mesh_to_deposit);
  h.add(r->deposit_samples);
  h.add(r->mesh_samples);
  for (const auto& l : r->per_layer) {
    h.add(l.layer);
    h.add(l.z_mm);
    h.add(l.deposit_to_mesh);
    h.add(l.mesh_to_deposit);
  }
  for (const auto& g : r->regions) {
    h.add(g.kind);
    h.add(g.bbox_mm.min);
    h.add(g.bbox_mm.max);
    h.add(g.area_mm2);
    h.add(g.worst_mm);
    h.add(g.worst_position_mm);
    h.add(g.samples);
    for (const long l : g.gcode_lines) h.add(l);
  }
  for (const double x :
       {r->max_excess_mm, r->max_deficit_mm, r->noise_area_mm2, r->deposit_volume_mm3})
    h.add(x);
  for (const std::size_t x : {r->noise_regions, r->surface_faces, r->surface_voxels}) h.add(x);
  for (const double x : r->vertex_deviation_mm) h.add(x);
  // The phases alone (public entry points), for attribution: the least CPU of 3 runs each.
  Box3 region{target->bbox_mm().min, target->bbox_mm().max};
  region.extend(p.part);
  region.min -= Vec3::Constant(settings.region_margin_mm);
  region.max += Vec3::Constant(settings.region_margin_mm);
  const auto least_of_3 = [](const auto& run) {
    double best = 1e30;
    for (int k = 0; k < 3; ++k) {
      const double t = cpu_s();
      run();
      best = std::min(best, cpu_s() - t);
    }
    return best;
  };
  DepositSurface surface;
  // The whole stage again: its memory comes from the allocator's free lists now, so the
  // difference to the first call is mostly the first touch of fresh pages.
  const double t_again = least_of_3([&] {
    auto again =
        compute_deviation(*target, Vec3::Zero(), p.deposit.grid, settings, p.part, p.beads);
    benchmark::DoNotOptimize(again->surface_faces);
  });
  const double t_surface = least_of_3([&] {
    surface = extract_outer_surface(p.deposit.grid, region, settings.seal_gap_mm,
                                    settings.groove_depth_mm);
  });
  const double t_beads =
      least_of_3([&] { place_on_beads(surface, p.beads, p.deposit.grid.voxel_mm()); });
  const std::vector<Vec3>& pts = surface.points_mm;
  std::vector<double> d;
  std::vector<std::uint32_t> tri;
  const double near_mm = std::max(4.0 * p.deposit.grid.voxel_mm(), settings.tolerance_mm);
  const std::vector<std::uint32_t> cells =
      surface.point_groups.empty() ? detail::face_cell_groups(surface) : surface.point_groups;
  const double t_dep =
      least_of_3([&] { target->signed_distances(Vec3::Zero(), pts, near_mm, d, &tri, cells); });
  std::vector<Vec3> q;
  for (const auto& s : target->samples()) q.push_back(s.position_mm);
  q.insert(q.end(), p.placed.vertices_mm.begin(), p.placed.vertices_mm.end());
  std::vector<std::uint32_t> nearest;
  const double t_mesh = least_of_3([&] { distances_to_deposit(surface, q, d, &nearest); });
  std::printf("checksum %016llx faces %zu mesh samples %zu\n", static_cast<unsigned long long>(h.h),
              r->surface_faces, r->mesh_to_deposit.samples);
  // The same samples whatever order the surface lists its faces in: the deposit samples by
  // position (a face centre is unique), then every figure that does not depend on the
  // order of summation (the regions' sets and the statistics' order statistics).
  {
    Hash c;
    const DeviationSamples& ds = r->deposit_samples;
    std::vector<std::uint32_t> by_pos(ds.size());
    for (std::uint32_t i = 0; i < by_pos.size(); ++i) by_pos[i] = i;
    std::sort(by_pos.begin(), by_pos.end(), [&](std::uint32_t a, std::uint32_t b) {
      const Vec3 &pa = ds.positions_mm[a], &pb = ds.positions_mm[b];
      return std::tie(pa.x(), pa.y(), pa.z()) < std::tie(pb.x(), pb.y(), pb.z());
    });
    for (const std::uint32_t i : by_pos) {
      const DeviationSample x = ds[i];
      c.add(x.position_mm);
      c.add(x.distance_mm);
      c.add(x.layer);
      c.add(x.line);
      c.add(x.triangle);
    }
    c.add(r->mesh_samples);
    for (const double x : r->vertex_deviation_mm) c.add(x);
    for (const DeviationStats* s : {&r->deposit_to_mesh, &r->mesh_to_deposit})
      for (const double x : {s->min_mm, s->max_mm, s->p50_abs_mm, s->p95_abs_mm, s->p99_abs_mm,
                             s->hausdorff_mm, s->within_tolerance_pct})
        c.add(x);
    for (const auto& g : r->regions) {
      c.add(g.kind);
      c.add(g.samples);
      c.add(g.worst_mm);
      for (const long l : g.gcode_lines) c.add(l);
    }
    std::printf(
        "order-free checksum %016llx (samples, vertex deviation, order statistics, regions)\n",
        static_cast<unsigned long long>(c.h));
  }
  std::printf(
      "cpu s: target %.3f deviation %.3f | least of 3: deviation %.3f surface %.3f beads %.3f "
      "deposit->mesh %.3f mesh->deposit %.3f\n",
      t1 - t0, t2 - t1, t_again, t_surface, t_beads, t_dep, t_mesh);
  return 0;
}

int export_points(int argc, char** argv) {
  if (argc < 5) return 2;
  VerifyOptions o;
  o.mesh_path = argv[2];
  o.gcode_path = argv[3];
  if (argc > 5) o.settings.voxel_mm = std::stod(argv[5]);
  auto r = verify(o);
  if (!r) {
    std::fprintf(stderr, "%s\n", r.error().describe().c_str());
    return 3;
  }
  std::vector<Vec3> pts;
  std::vector<double> d;
  for (const auto& s : r->deviation.deposit_samples) {
    pts.push_back(s.position_mm);
    d.push_back(s.distance_mm);
  }
  const std::filesystem::path dir = argv[4];
  // Points only (CloudCompare's C2M distance is then the cloud's only scalar field).
  if (!write_file_atomic(dir / "points.ply", points_ply(pts, {})).ok()) return 3;
  if (!save_stl(r->placed_mesh, dir / "mesh.stl").ok()) return 3;
  const auto& s = r->deviation.deposit_to_mesh;
  std::printf("exported %zu points; ours in-process: mean|d| %.9f rms %.9f max|d| %.9f\n",
              pts.size(), s.mean_abs_mm, s.rms_mm, s.hausdorff_mm);
  return 0;
}

/// Reads the binary PLY written by points_ply (doubles x y z [deviation]).
bool read_points(const std::string& path, std::vector<Vec3>& pts) {
  auto text = read_file(path);
  if (!text) return false;
  const auto end = text->find("end_header\n");
  if (end == std::string::npos) return false;
  std::istringstream header(text->substr(0, end));
  std::string line;
  std::size_t n = 0, props = 0;
  while (std::getline(header, line)) {
    if (line.rfind("element vertex ", 0) == 0) n = std::stoul(line.substr(15));
    if (line.rfind("property double ", 0) == 0) ++props;
  }
  const char* data = text->data() + end + 11;
  if (text->size() < end + 11 + n * props * 8) return false;
  pts.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a)
      std::memcpy(&pts[i][a], data + (i * props + static_cast<std::size_t>(a)) * 8, 8);
  return true;
}

int c2m(int argc, char** argv) {
  if (argc < 4) return 2;
  std::vector<Vec3> pts;
  if (!read_points(argv[2], pts)) return 3;
  auto mesh = load_mesh(argv[3]);
  if (!mesh) return 3;
  auto d = signed_distances_to_mesh(*mesh, pts, 0.2);
  if (!d) return 3;
  long double sum = 0, sum2 = 0;
  double mx = 0;
  for (const double v : *d) {
    sum += std::abs(v);
    sum2 += static_cast<long double>(v) * v;
    mx = std::max(mx, std::abs(v));
  }
  const auto n = static_cast<long double>(d->size());
  std::printf("n %zu mean_abs %.9f rms %.9f max_abs %.9f\n", d->size(),
              static_cast<double>(sum / n), static_cast<double>(std::sqrt(sum2 / n)), mx);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::strcmp(argv[1], "--export") == 0) return export_points(argc, argv);
  if (argc > 1 && std::strcmp(argv[1], "--c2m") == 0) return c2m(argc, argv);
  if (argc > 1 && std::strcmp(argv[1], "--checksum") == 0) return checksum();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
