// compare.md, compare.html and the chart of a hand-made comparison.
#include <gtest/gtest.h>

#include <regex>
#include <sstream>

#include "compare/hand_made_result.hpp"
#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

using test::hand_made_result;

// ---------------------------------------------------------------- Markdown and HTML

TEST(CompareOutputs, MarkdownTable) {
  const std::string md = compare_markdown(hand_made_result());
  EXPECT_NE(md.find("# printtwin compare: ramp"), std::string::npos);
  EXPECT_NE(md.find("**6 variants**: 5 ran, 2 pass, 1 could not run."), std::string::npos) << md;
  // Row of variant 0: 1 h 00 min, 1.50 m / 4.5 g, RMS 0.045, slopes 0.068.
  EXPECT_NE(md.find("| 0 | layer_height=0.1 | 1 h 00 min | 1.50 m / 4.5 g | 0.045 | 0.068 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("Pareto-optimal (print time vs deviation RMS): **layer_height=0.1**, "
                    "**layer_height=0.15**, **layer_height=0.2**, **layer_height=0.3**."),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("broken.gcode:12: expected a number after X"), std::string::npos);
}

TEST(CompareOutputs, HtmlIsSelfContainedWithChartAndFront) {
  const CompareResult r = hand_made_result();
  const std::string html = compare_html(r, {"2026-11-21T10:00:00Z"});
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("href=\"http"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_NE(html.find("<svg class=\"chart\" id=\"tradeoff\""), std::string::npos);
  // One ring per Pareto-optimal variant, one point per variant that ran.
  auto count = [&](const std::string& needle) {
    std::size_t n = 0;
    for (auto at = html.find(needle); at != std::string::npos; at = html.find(needle, at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("class=\"ring\""), 4u);
  EXPECT_EQ(count("class=\"pt pt-"), 5u);
  EXPECT_EQ(count("class=\"front\""), 1u);
  EXPECT_EQ(count("<tr class=\"pareto\">"), 4u);
  EXPECT_EQ(count("<details class=\"variant\""), 6u);
  EXPECT_NE(html.find("href=\"variants/00-x/report.html\""), std::string::npos);
  EXPECT_NE(html.find("2026-11-21T10:00:00Z"), std::string::npos);
  // Deterministic.
  EXPECT_EQ(compare_html(r, {"2026-11-21T10:00:00Z"}), html);
}

TEST(CompareOutputs, ChartPlacesPointsByTimeAndRms) {
  const std::string svg = compare_chart_svg(hand_made_result());
  // The front staircase starts at the fastest variant (1300 s, bottom-right of its RMS) and
  // ends at the slowest optimal one; its points are in increasing x.
  const std::regex poly(R"(<polyline class="front" points="([^"]+)\")");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, poly));
  std::vector<double> xs, ys;
  std::stringstream ss(m[1].str());
  std::string pt;
  while (ss >> pt) {
    const auto comma = pt.find(',');
    xs.push_back(std::stod(pt.substr(0, comma)));
    ys.push_back(std::stod(pt.substr(comma + 1)));
  }
  ASSERT_EQ(xs.size(), 7u);  // 4 points + 3 corners
  for (std::size_t i = 1; i < xs.size(); ++i) EXPECT_GE(xs[i], xs[i - 1]);
  // RMS grows up the page (SVG y grows down): along the front, from the fastest variant to
  // the most accurate one, the RMS falls, so the staircase goes down the page.
  EXPECT_GT(ys.back(), ys.front());
  for (std::size_t i = 1; i < ys.size(); ++i) EXPECT_GE(ys[i], ys[i - 1]);
}

TEST(CompareOutputs, WritesThreeFiles) {
  const auto dir = test::temp_dir("compare_outputs");
  ASSERT_TRUE(write_compare_outputs(hand_made_result(), dir / "out").ok());
  for (const char* f : {"compare.json", "compare.md", "compare.html"}) {
    auto text = read_file(dir / "out" / f);
    ASSERT_TRUE(text.ok()) << f;
    EXPECT_GT(text->size(), 500u) << f;
  }
}

TEST(CompareOutputs, MergedSharesGiveTheSameMarkdownAndHtml) {
  const CompareResult whole = hand_made_result();
  std::vector<CompareResult> shares;
  for (int k = 0; k < 4; ++k) {
    CompareResult s = whole;
    s.shard = std::make_pair(k, 4);
    s.variants.clear();
    const std::vector<int> share = shard_indices(whole.variant_count, k, 4).value();
    for (int i : share) s.variants.push_back(whole.variants[static_cast<std::size_t>(i)]);
    mark_pareto(s.variants);
    shares.push_back(*parse_compare_json(compare_json(s), "share"));
  }
  auto merged = merge_compare_results(shares);
  ASSERT_TRUE(merged.ok()) << merged.error().describe();
  EXPECT_EQ(compare_markdown(*merged), compare_markdown(whole));
  EXPECT_EQ(compare_chart_svg(*merged), compare_chart_svg(whole));
}

}  // namespace
}  // namespace printtwin
