// Report stage: colour scale, PNG, heatmap renders, cross-sections, JUnit/Markdown/HTML text
// and the atomic folder writer, on a synthetic VerifyReport with a known deviation field.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <sstream>

#include "printtwin/io.hpp"
#include "printtwin/mesh_query.hpp"
#include "printtwin/report.hpp"
#include "report/heatmap.hpp"
#include "report/synthetic_report.hpp"
#include "report/xml_checker.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

using test::kBulgeAt;
using test::kDentAt;
using test::kSyntheticCenter;

const VerifyReport& synthetic() {
  static const VerifyReport r = test::make_synthetic_report();
  return r;
}

ViewSpec find_view(const std::string& name) {
  for (const auto& v : default_views())
    if (v.name == name) return v;
  return {};
}

std::array<int, 3> pixel(const Image& im, const Vec2& p) {
  const int x = static_cast<int>(std::floor(p.x())), y = static_cast<int>(std::floor(p.y()));
  const std::size_t i = 4 * (static_cast<std::size_t>(y) * im.width + x);
  return {im.rgba[i], im.rgba[i + 1], im.rgba[i + 2]};
}

TEST(ReportColorScale, GreenWithinToleranceBlueDeficitRedExcess) {
  const DeviationColorScale s{0.2, 1.0};
  for (double d : {0.0, 0.1, -0.19, 0.2, -0.2}) {
    const auto c = s.color(d);
    EXPECT_GT(c[1], c[0] + 15) << d;
    EXPECT_GT(c[1], c[2] + 15) << d;
  }
  // Inside the band the sign still reads: bluer below zero, redder above.
  EXPECT_GT(s.color(-0.15)[2], s.color(0.15)[2]);
  EXPECT_GT(s.color(0.15)[0], s.color(-0.15)[0]);
  for (double d : {-0.21, -0.5, -1.0, -3.0}) {
    const auto c = s.color(d);
    EXPECT_GT(c[2], c[0] + 60) << d;
  }
  for (double d : {0.21, 0.5, 1.0, 3.0}) {
    const auto c = s.color(d);
    EXPECT_GT(c[0], c[2] + 60) << d;
  }
  // Darker further out, saturating at the range.
  auto lum = [&](double d) {
    const auto c = s.color(d);
    return 0.3 * c[0] + 0.59 * c[1] + 0.11 * c[2];
  };
  EXPECT_GT(lum(0.25), lum(0.6));
  EXPECT_GT(lum(0.6), lum(1.0));
  EXPECT_GT(lum(-0.25), lum(-0.9));
  EXPECT_EQ(s.color(1.0), s.color(5.0));
}

TEST(ReportColorScale, RangeIsANiceNumberBetweenTwoAndTenTolerances) {
  DeviationResult d;
  d.tolerance_mm = 0.2;
  d.vertex_deviation_mm = {0.1, -0.83, 0.3};
  EXPECT_DOUBLE_EQ(make_color_scale(d).range_mm, 1.0);
  d.vertex_deviation_mm = {0.05};
  EXPECT_DOUBLE_EQ(make_color_scale(d).range_mm, 0.4);  // at least 2 tolerances
  d.vertex_deviation_mm = {7.3};
  EXPECT_DOUBLE_EQ(make_color_scale(d).range_mm, 2.0);                      // at most 10 tolerances
  EXPECT_DOUBLE_EQ(make_color_scale(synthetic().deviation).range_mm, 1.0);  // worst -0.85
}

TEST(ReportPng, RoundTripIsExactAndDeterministic) {
  Image im{7, 5, {}};
  for (int i = 0; i < 7 * 5 * 4; ++i) im.rgba.push_back(static_cast<std::uint8_t>((i * 37) % 256));
  auto png = encode_png(im);
  ASSERT_TRUE(png.ok());
  EXPECT_EQ(png->substr(1, 3), "PNG");
  auto back = decode_png(*png);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, im);
  EXPECT_EQ(*encode_png(im), *png);
  EXPECT_FALSE(decode_png("not a png").ok());
  EXPECT_FALSE(encode_png(Image{3, 3, {1, 2, 3}}).ok());
}

TEST(ReportRender, TopViewOfSphereCoversItsDiscAndShowsTheBulgeInRed) {
  const auto& r = synthetic();
  const DeviationColorScale scale = make_color_scale(r.deviation);
  SurfaceDeviationField field{r.deviation.mesh_samples.positions_mm,
                              r.deviation.mesh_samples.distances_mm,
                              r.deviation.vertex_deviation_mm, 0.25};
  const HeatmapView top = render_heatmap(r.placed_mesh, field, scale, find_view("top"));
  // Disc of radius 12 mm (polygon of 96 segments: area factor sin(2pi/96)*96/(2pi)).
  const double disc_mm2 = 0.5 * 96 * std::sin(2 * 3.14159265358979 / 96) * 144.0;
  const double px_mm2 = top.camera.mm_per_px * top.camera.mm_per_px;
  EXPECT_NEAR(static_cast<double>(top.hit_pixels) * px_mm2, disc_mm2, 0.02 * disc_mm2);
  // Square part -> square image, cropped to the part plus margins.
  EXPECT_EQ(top.image.width, top.image.height);
  EXPECT_NEAR(top.camera.mm_per_px * (top.image.width - 20), 24.0, 0.1);
  // The bulge (excess 0.55 mm) is red, the centre of the ripple-only cap is green.
  const auto bulge = pixel(top.image, top.camera.project(kBulgeAt));
  EXPECT_GT(bulge[0], bulge[2] + 60);
  EXPECT_GT(bulge[0], bulge[1]);
  const auto cap = pixel(top.image, top.camera.project(kSyntheticCenter + Vec3(-3, -3, 0)));
  EXPECT_GT(cap[1], cap[0] + 20);
  EXPECT_GT(cap[1], cap[2] + 20);
  // Corners are background (transparent).
  EXPECT_EQ(top.image.rgba[3], 0);

  const HeatmapView front = render_heatmap(r.placed_mesh, field, scale, find_view("front"));
  const auto dent = pixel(front.image, front.camera.project(kDentAt));
  EXPECT_GT(dent[2], dent[0] + 60);
  // Same inputs, same pixels.
  EXPECT_EQ(render_heatmap(r.placed_mesh, field, scale, find_view("front")).image, front.image);
}

TEST(ReportRender, VertexDeviationColoursWhenThereAreNoSamples) {
  const Mesh box = make_box_mesh(Vec3(0, 0, 0), Vec3(20, 20, 10));
  // Vertices with x = 20 are +0.6 (excess), x = 0 are -0.6: the top face runs blue -> green -> red.
  std::vector<double> dev;
  for (const auto& v : box.vertices_mm) dev.push_back(v.x() > 10 ? 0.6 : -0.6);
  SurfaceDeviationField field{{}, {}, dev, 0};
  const HeatmapView top =
      render_heatmap(box, field, DeviationColorScale{0.2, 1.0}, find_view("top"));
  const auto left = pixel(top.image, top.camera.project(Vec3(1, 10, 10)));
  const auto mid = pixel(top.image, top.camera.project(Vec3(10, 10, 10)));
  const auto right = pixel(top.image, top.camera.project(Vec3(19, 10, 10)));
  EXPECT_GT(left[2], left[0] + 60);
  EXPECT_GT(mid[1], mid[0] + 20);
  EXPECT_GT(mid[1], mid[2] + 20);
  EXPECT_GT(right[0], right[2] + 60);
}

// The raster is what one ray per pixel centre would see: for every pixel of every default
// view of the synthetic sphere, Embree's first hit along the view direction from the pixel's
// ray origin has the same triangle (or another at the same depth: a shared edge) and the same
// depth, and a pixel is background exactly when the ray misses (a silhouette pixel or two
// may go either way).
TEST(ReportRender, RasterMatchesARayCastPerPixel) {
  const auto& r = synthetic();
  auto q = MeshQuery::build(r.placed_mesh);
  ASSERT_TRUE(q.ok());
  for (const ViewSpec& view : default_views()) {
    const TracedView tv = trace_heatmap_view(r.placed_mesh, view);
    const int w = tv.camera.width_px, h = tv.camera.height_px;
    std::size_t hits = 0, disagree = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        const auto hit = q->first_hit(tv.pixel_origin(x, y), tv.camera.forward);
        const bool raster = tv.triangle[i] != TracedView::kNoHit;
        if (raster != hit.has_value()) {
          ++disagree;
          continue;
        }
        if (!raster) continue;
        ++hits;
        EXPECT_NEAR(tv.depth_mm[i], hit->t_mm, 1e-3) << view.name << " pixel " << x << "," << y;
        if (tv.triangle[i] != hit->triangle) {
          // Another triangle at the same depth: both share the point the ray hits.
          const auto& tri = r.placed_mesh.triangles[tv.triangle[i]];
          const Vec3 p =
              tv.pixel_origin(x, y) + tv.camera.forward * static_cast<double>(tv.depth_mm[i]);
          const Vec3 c = closest_point_on_triangle(p, r.placed_mesh.vertices_mm[tri[0]],
                                                   r.placed_mesh.vertices_mm[tri[1]],
                                                   r.placed_mesh.vertices_mm[tri[2]]);
          EXPECT_LT((c - p).norm(), 1e-3) << view.name << " pixel " << x << "," << y;
        }
      }
    EXPECT_GT(hits, 10000U) << view.name;
    EXPECT_LE(disagree, hits / 1000) << view.name;  // silhouette pixels only
  }
}

TEST(ReportRender, RegionMarkersKnowWhichSideTheyAreOn) {
  const auto& r = synthetic();
  const TracedView top = trace_heatmap_view(r.placed_mesh, find_view("top"));
  const auto m = mark_regions(top, r.deviation.regions);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_TRUE(m[0].visible);   // bulge on the upper half
  EXPECT_FALSE(m[1].visible);  // dent on the lower half
  const Vec2 expect = top.camera.project(r.deviation.regions[0].worst_position_mm);
  EXPECT_NEAR((m[0].worst_px - expect).norm(), 0.0, 1e-9);
  EXPECT_LE(m[0].bbox_min_px.x(), m[0].worst_px.x());
  EXPECT_GE(m[0].bbox_max_px.y(), m[0].worst_px.y());
  const auto mi =
      mark_regions(trace_heatmap_view(r.placed_mesh, find_view("iso")), r.deviation.regions);
  EXPECT_FALSE(mi[0].visible);  // bulge faces away from the front-left-top camera
  EXPECT_TRUE(mi[1].visible);
}

double loop_length(const std::vector<Vec2>& p) {
  double len = 0;
  for (std::size_t i = 1; i < p.size(); ++i) len += (p[i] - p[i - 1]).norm();
  return len;
}
double loop_area(const std::vector<Vec2>& p) {
  double a = 0;
  for (std::size_t i = 1; i < p.size(); ++i) a += p[i - 1].x() * p[i].y() - p[i].x() * p[i - 1].y();
  return 0.5 * std::abs(a);
}

TEST(ReportSections, BoxAndSphereCutsAreClosedLoopsWithTheRightSize) {
  const Mesh box = make_box_mesh(Vec3(5, 5, 0), Vec3(25, 15, 10));
  const std::vector<double> z = {5.0, 0.0, 10.0, 12.0, 2.5};
  const auto cuts = cut_mesh(box, z, 0.01);
  ASSERT_EQ(cuts.size(), z.size());
  ASSERT_EQ(cuts[0].size(), 1u);
  const auto& loop = cuts[0][0];
  EXPECT_EQ(loop.size(), 5u);  // 4 corners + the closing point after simplification
  EXPECT_EQ(loop.front(), loop.back());
  EXPECT_NEAR(loop_length(loop), 60.0, 1e-9);
  EXPECT_NEAR(loop_area(loop), 200.0, 1e-9);
  EXPECT_TRUE(cuts[1].empty());  // z = min: below-rule puts every vertex above
  EXPECT_TRUE(cuts[3].empty());  // above the part
  ASSERT_EQ(cuts[4].size(), 1u);
  EXPECT_NEAR(loop_area(cuts[4][0]), 200.0, 1e-9);

  const Mesh sphere = test::make_uv_sphere(Vec3(0, 0, 0), 10.0, 128, 64);
  const std::vector<double> equator = {1e-3};
  const auto s = cut_mesh(sphere, equator, 0.0);
  ASSERT_EQ(s.size(), 1u);
  ASSERT_EQ(s[0].size(), 1u);
  // z = 1e-3 is just above the equator ring: each quad of the band is cut on its two sides
  // and its diagonal, 2 points per segment plus the closing point.
  EXPECT_EQ(s[0][0].size(), 257u);
  EXPECT_NEAR(loop_length(s[0][0]), 2 * 3.14159265358979 * 10.0, 0.01 * 62.8);
  // Simplification keeps the shape within its tolerance and drops points.
  const auto simplified = cut_mesh(sphere, equator, 0.05)[0][0];
  EXPECT_LT(simplified.size(), 129u);
  EXPECT_NEAR(loop_area(simplified), loop_area(s[0][0]), 0.01 * loop_area(s[0][0]));
}

TEST(ReportJunit, StructureCountsAndEscapesParseBack) {
  ReportOptions opt;
  opt.generated_utc = "2026-11-21T10:20:00Z";
  const auto& r = synthetic();
  const std::string xml = report_junit_xml(r, opt);
  auto doc = test::parse_xml(xml);
  ASSERT_TRUE(doc.ok()) << doc.error().message;
  const test::XmlElement& root = *doc;
  EXPECT_EQ(root.name, "testsuites");
  int tests = 0, failures = 0;
  ASSERT_EQ(root.children.size(), 2u);
  for (const auto& suite : root.children) {
    EXPECT_EQ(suite.name, "testsuite");
    int cases = 0, failed = 0;
    for (const auto& c : suite.children) {
      if (c.name == "properties") continue;
      EXPECT_EQ(c.name, "testcase");
      EXPECT_FALSE(c.attr("name").empty());
      EXPECT_FALSE(c.attr("classname").empty());
      EXPECT_EQ(c.attr("time"), "0");
      ++cases;
      for (const auto& f : c.children) {
        EXPECT_EQ(f.name, "failure");
        EXPECT_FALSE(f.attr("message").empty());
        ++failed;
      }
    }
    EXPECT_EQ(suite.attr("tests"), std::to_string(cases));
    EXPECT_EQ(suite.attr("failures"), std::to_string(failed));
    EXPECT_EQ(suite.attr("errors"), "0");
    EXPECT_EQ(suite.attr("timestamp"), "2026-11-21T10:20:00");
    tests += cases;
    failures += failed;
  }
  EXPECT_EQ(root.attr("tests"), std::to_string(tests));
  EXPECT_EQ(root.attr("failures"), std::to_string(failures));
  // 3 gates (excess and deficit fail, error findings fail) + 2 error findings (warning excluded).
  EXPECT_EQ(tests, 5);
  EXPECT_EQ(failures, 5);
  EXPECT_EQ(root.children[0].attr("name"), "printtwin.verify.synthetic_sphere.gates");
  EXPECT_DOUBLE_EQ(std::stod(root.attr("time")), 2.412);
  // The finding's message survives escaping unchanged.
  const auto& finding_case = root.children[1].children.at(0);
  EXPECT_EQ(finding_case.children.at(0).attr("message"), r.findings[1].message);
  EXPECT_NE(finding_case.children.at(0).attr("message").find("<beyond>"), std::string::npos);
  // Deterministic.
  EXPECT_EQ(report_junit_xml(r, opt), xml);
}

TEST(ReportJunit, PassingReportHasNoFailures) {
  VerifyReport r;
  r.part_name = "cube";
  r.pass = true;
  r.gates = {{"max_excess", 0.3, 0.12, true}, {"max_deficit", 0.3, 0.2, true}};
  auto doc = test::parse_xml(report_junit_xml(r));
  ASSERT_TRUE(doc.ok()) << doc.error().message;
  EXPECT_EQ(doc->attr("tests"), "2");
  EXPECT_EQ(doc->attr("failures"), "0");
  EXPECT_TRUE(doc->children[0].children[1].children.empty());
  EXPECT_EQ(doc->children[1].attr("tests"), "0");
}

TEST(ReportMarkdown, VerdictGateTableAndRegions) {
  const std::string md = report_summary_markdown(synthetic());
  EXPECT_NE(md.find("FAIL"), std::string::npos);
  EXPECT_NE(md.find("| Gate | Limit | Value | Result |"), std::string::npos);
  EXPECT_NE(md.find("| Max excess | 0.200 mm | "), std::string::npos);
  EXPECT_NE(md.find("| Error findings | 0 | 2 | **FAIL** |"), std::string::npos);
  EXPECT_NE(md.find("| 2 | missing | "), std::string::npos);
  EXPECT_NE(md.find("1 h 02 min"), std::string::npos);  // 3725.5 s
  // Every table row has the header's column count.
  std::istringstream in(md);
  std::string line;
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.rfind("| Gate", 0) == 0) {
      for (int k = 0; k < 5 && std::getline(in, line); ++k) {
        if (line.empty()) break;
        EXPECT_EQ(std::count(line.begin(), line.end(), '|'), 5) << line;
        ++rows;
      }
    }
  }
  EXPECT_EQ(rows, 4);  // separator + 3 gates
}

TEST(ReportHtml, SelfContainedSmallAndDeterministic) {
  ReportOptions opt;
  opt.generated_utc = "2026-11-21T10:20:00Z";
  auto files = build_report_files(synthetic(), opt);
  ASSERT_TRUE(files.ok()) << files.error().message;
  std::map<std::string, std::string> by_name;
  for (const auto& f : *files) by_name[f.name] = f.content;
  ASSERT_TRUE(by_name.count("report.html"));
  const std::string& html = by_name["report.html"];
  EXPECT_LT(html.size(), 5u * 1024 * 1024);
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  EXPECT_EQ(html.find("src=\"//"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  // One embedded PNG per view, and the same PNGs as files.
  std::size_t pngs = 0;
  for (std::size_t p = html.find("data:image/png;base64,"); p != std::string::npos;
       p = html.find("data:image/png;base64,", p + 1))
    ++pngs;
  EXPECT_EQ(pngs, default_views().size());
  for (const auto& v : default_views())
    EXPECT_TRUE(by_name.count("heatmap_" + v.name + ".png")) << v.name;
  // The verdict, both region rows, the inputs' hashes and the version are on the page.
  EXPECT_NE(html.find("<div class=\"badge\">FAIL</div>"), std::string::npos);
  EXPECT_NE(html.find("data-region=\"2\" data-layer="), std::string::npos);
  EXPECT_NE(html.find(std::string(64, 'b')), std::string::npos);
  EXPECT_NE(html.find("0.1.0-test"), std::string::npos);
  // Text from the report is escaped.
  EXPECT_NE(html.find("&lt;beyond&gt; the &quot;tolerance&quot; &amp; limit"), std::string::npos);
  // Same inputs, same bytes (the timestamp is an input).
  auto again = build_report_files(synthetic(), opt);
  ASSERT_TRUE(again.ok());
  for (std::size_t i = 0; i < files->size(); ++i)
    EXPECT_EQ((*again)[i].content, (*files)[i].content) << (*files)[i].name;
}

// The traced views of a placed mesh serve every report on it: the same bytes with the cache
// as without, for the report it was built from and for another deviation result on the same
// mesh (compare's next variant). A cache of another placement is not used.
TEST(ReportHeatmapCache, SameBytesWithAndWithoutTheCache) {
  ReportOptions plain;
  plain.generated_utc = "2026-11-21T10:20:00Z";
  auto cache = build_heatmap_cache(synthetic().placed_mesh, plain.views);
  ASSERT_TRUE(cache.ok()) << cache.error().message;
  ASSERT_TRUE(cache->fits(synthetic().placed_mesh, plain.views));
  const HeatmapCache* cached = &*cache;

  VerifyReport other = synthetic();
  for (double& d : other.deviation.mesh_samples.distances_mm) d = 0.4 - 0.7 * d;
  for (double& d : other.deviation.vertex_deviation_mm) d = 0.4 - 0.7 * d;
  // Vertex colours only: the barycentric fallback reads the cached hits.
  VerifyReport vertex_only = synthetic();
  vertex_only.deviation.mesh_samples.clear();
  const std::array<const VerifyReport*, 3> reports{&synthetic(), &other, &vertex_only};
  for (const VerifyReport* r : reports) {
    auto a = render_report_assets(*r, plain);
    auto b = detail::render_report_assets(*r, plain, cached);
    ASSERT_TRUE(a.ok() && b.ok());
    ASSERT_EQ(a->views.size(), b->views.size());
    for (std::size_t i = 0; i < a->views.size(); ++i) {
      EXPECT_EQ(a->views[i].image, b->views[i].image) << a->views[i].view.name;
      EXPECT_EQ(a->views[i].hit_pixels, b->views[i].hit_pixels);
      EXPECT_EQ(a->view_png[i], b->view_png[i]);
      ASSERT_EQ(a->views[i].markers.size(), b->views[i].markers.size());
      for (std::size_t m = 0; m < a->views[i].markers.size(); ++m) {
        EXPECT_EQ(a->views[i].markers[m].worst_px, b->views[i].markers[m].worst_px);
        EXPECT_EQ(a->views[i].markers[m].visible, b->views[i].markers[m].visible);
      }
    }
    auto fa = build_report_files(*r, plain);
    auto fb = detail::build_report_files(*r, plain, cached);
    ASSERT_TRUE(fa.ok() && fb.ok());
    ASSERT_EQ(fa->size(), fb->size());
    for (std::size_t i = 0; i < fa->size(); ++i)
      EXPECT_EQ((*fa)[i].content, (*fb)[i].content) << (*fa)[i].name;
  }
  // The colours differ between the two results: the cache holds no colour.
  EXPECT_NE(detail::render_report_assets(other, plain, cached)->views[0].image,
            detail::render_report_assets(synthetic(), plain, cached)->views[0].image);

  // The cache is what the renders read: a tampered one shows.
  HeatmapCache dark = std::move(*cache);
  for (double& s : dark.views[0].shade) s *= 0.5;
  cached = &dark;
  EXPECT_NE(detail::render_report_assets(synthetic(), plain, cached)->views[0].image,
            render_report_assets(synthetic(), plain)->views[0].image);

  // Another placement (a variant registered 0.25 mm off) or other views: not used.
  VerifyReport moved = synthetic();
  for (Vec3& v : moved.placed_mesh.vertices_mm) v += Vec3(0.25, 0, 0);
  EXPECT_FALSE(dark.fits(moved.placed_mesh, plain.views));
  EXPECT_FALSE(dark.fits(synthetic().placed_mesh,
                         std::vector<ViewSpec>(plain.views.begin(), plain.views.end() - 1)));
  auto m_plain = render_report_assets(moved, plain);
  auto m_cached = detail::render_report_assets(moved, plain, cached);
  ASSERT_TRUE(m_plain.ok() && m_cached.ok());
  for (std::size_t i = 0; i < m_plain->views.size(); ++i)
    EXPECT_EQ(m_plain->view_png[i], m_cached->view_png[i]);
}

// A writer of several reports (compare's variants) writes the same bytes as
// write_report_folder, whether the next report's placed mesh is the same or another.
TEST(ReportFolderWriter, SameFilesAsWriteReportFolder) {
  const auto dir = test::temp_dir("report_folder_writer");
  ReportOptions options;
  options.generated_utc = "2026-11-21T10:20:00Z";
  VerifyReport other = synthetic();
  for (double& d : other.deviation.vertex_deviation_mm) d = 0.4 - 0.7 * d;
  VerifyReport moved = synthetic();
  for (Vec3& v : moved.placed_mesh.vertices_mm) v += Vec3(0.25, 0, 0);
  ReportFolderWriter writer;
  const std::array<const VerifyReport*, 3> reports{&synthetic(), &other, &moved};
  for (std::size_t i = 0; i < reports.size(); ++i) {
    const auto a = dir / ("plain" + std::to_string(i)), b = dir / ("writer" + std::to_string(i));
    ASSERT_TRUE(write_report_folder(*reports[i], a, options).ok());
    ASSERT_TRUE(writer.write(*reports[i], b, options).ok());
    std::size_t files = 0;
    for (const auto& entry : std::filesystem::directory_iterator(a)) {
      const auto name = entry.path().filename();
      EXPECT_EQ(*read_file(entry.path()), *read_file(b / name)) << name;
      ++files;
    }
    EXPECT_EQ(files,
              static_cast<std::size_t>(std::distance(std::filesystem::directory_iterator(b),
                                                     std::filesystem::directory_iterator())));
    EXPECT_GT(files, 3u);
  }
}

TEST(ReportFolder, WritesEveryFileAndReplacesAnOldReportAtomically) {
  const auto dir = test::temp_dir("report_folder");
  const auto out = dir / "reports" / "sphere";
  std::filesystem::create_directories(out);
  ASSERT_TRUE(write_file_atomic(out / "stale.txt", "old").ok());
  ReportOptions opt;
  // As `printtwin verify` does: report.json and deviation.ply join the staging folder.
  opt.extra_outputs = [](const std::filesystem::path& staging) -> Status {
    if (auto st = write_verify_outputs(synthetic(), staging); !st) return st;
    return write_file_atomic(staging / "deposit.ot", "octree");
  };
  ASSERT_TRUE(write_report_folder(synthetic(), out, opt).ok());
  for (const char* f : {"report.html", "junit.xml", "summary.md", "heatmap_iso.png", "report.json",
                        "deviation.ply", "deposit.ot"})
    EXPECT_TRUE(std::filesystem::exists(out / f)) << f;
  EXPECT_FALSE(std::filesystem::exists(out / "stale.txt"));
  // Nothing else is left beside it (no staging or old folders, no temporary files).
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir / "reports"))
    names.push_back(e.path().filename());
  EXPECT_EQ(names, std::vector<std::string>{"sphere"});
  for (const auto& e : std::filesystem::directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  auto png = read_file(out / "heatmap_top.png");
  ASSERT_TRUE(png.ok());
  auto img = decode_png(*png);
  ASSERT_TRUE(img.ok());
  EXPECT_GT(img->width, 100);
}

TEST(ReportFolder, AFailedRunLeavesTheOldReportAndNoHalfWrittenOne) {
  const auto dir = test::temp_dir("report_folder_fail");
  const auto out = dir / "part";
  ASSERT_TRUE(write_file_atomic(out / "report.html", "previous").ok());
  ReportOptions opt;
  opt.extra_outputs = [](const std::filesystem::path&) -> Status {
    return bad_input("deposit export failed");
  };
  const auto st = write_report_folder(synthetic(), out, opt);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().message, "deposit export failed");
  EXPECT_EQ(*read_file(out / "report.html"), "previous");
  std::size_t entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    entries += e.path().filename() == "part" ? 0 : 1;
  EXPECT_EQ(entries, 0u);
  // A fresh target that fails is not created at all.
  EXPECT_FALSE(write_report_folder(synthetic(), dir / "fresh", opt).ok());
  EXPECT_FALSE(std::filesystem::exists(dir / "fresh"));
  // A file where the folder should be is bad input.
  ASSERT_TRUE(write_file_atomic(dir / "afile", "x").ok());
  const auto st2 = write_report_folder(synthetic(), dir / "afile", ReportOptions{});
  ASSERT_FALSE(st2.ok());
  EXPECT_EQ(st2.error().code, ErrorCode::bad_input);
}

}  // namespace
}  // namespace printtwin
