// compare without running any variant: variant expansion, sharding, the Pareto front on a
// hand-made result set, compare.json round trip, the merge of shares, the manifest, and the
// Markdown / HTML outputs.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <regex>
#include <sstream>

#include "compare/hand_made_result.hpp"
#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

using test::hand_made_result;

std::vector<std::string> labels_of(const std::vector<VariantSpec>& v) {
  std::vector<std::string> out;
  for (const auto& s : v) out.push_back(s.label);
  return out;
}

TEST(CompareVariants, ParsesSweepAxes) {
  auto a = parse_sweep_axis("layer-height=0.1, 0.15 ,0.2");
  ASSERT_TRUE(a.ok()) << a.error().describe();
  EXPECT_EQ(a->key, "layer_height");  // '-' and '_' are the same key, as in the slicer
  EXPECT_EQ(a->values, (std::vector<std::string>{"0.1", "0.15", "0.2"}));

  for (const char* bad :
       {"layer_height", "=0.1", "layer_height=", "layer_height=0.1,,0.2", "layer_height=0.1,0.1"}) {
    auto r = parse_sweep_axis(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, ErrorCode::usage) << bad;
  }
}

TEST(CompareVariants, CrossProductIsDeterministicFirstAxisSlowest) {
  SweepSpec spec;
  spec.common_settings = {{"perimeters", "3"}};
  spec.axes = {*parse_sweep_axis("layer_height=0.1,0.15,0.2,0.3"),
               *parse_sweep_axis("infill_density=15,40")};
  auto v = expand_variants(spec);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  ASSERT_EQ(v->size(), 8u);
  EXPECT_EQ(labels_of(*v),
            (std::vector<std::string>{
                "layer_height=0.1 infill_density=15", "layer_height=0.1 infill_density=40",
                "layer_height=0.15 infill_density=15", "layer_height=0.15 infill_density=40",
                "layer_height=0.2 infill_density=15", "layer_height=0.2 infill_density=40",
                "layer_height=0.3 infill_density=15", "layer_height=0.3 infill_density=40"}));
  for (int i = 0; i < 8; ++i) {
    const auto& s = (*v)[static_cast<std::size_t>(i)];
    EXPECT_EQ(s.index, i);
    EXPECT_EQ(s.kind, VariantKind::slicer);
    // Common settings first, then the swept values in axis order.
    ASSERT_EQ(s.settings.size(), 3u);
    EXPECT_EQ(s.settings[0], (SettingKV{"perimeters", "3"}));
    EXPECT_EQ(s.settings[1].first, "layer_height");
    EXPECT_EQ(s.settings[2].first, "infill_density");
  }
  // Same input, same list.
  auto again = expand_variants(spec);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *v);
}

TEST(CompareVariants, ConfigsTimesAxesThenGcodes) {
  SweepSpec spec;
  spec.configs = {"cfg/fast.ini", "other/fine.ini", "x/fast.ini"};
  spec.axes = {*parse_sweep_axis("layer_height=0.1,0.2")};
  spec.gcodes = {"out/prusa.gcode", "out/cura.gcode"};
  auto v = expand_variants(spec);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  ASSERT_EQ(v->size(), 8u);
  EXPECT_EQ(labels_of(*v),
            (std::vector<std::string>{"fast layer_height=0.1", "fast layer_height=0.2",
                                      "fine layer_height=0.1", "fine layer_height=0.2",
                                      "fast (2) layer_height=0.1", "fast (2) layer_height=0.2",
                                      "prusa", "cura"}));
  EXPECT_EQ((*v)[2].config_path, "other/fine.ini");
  EXPECT_EQ((*v)[6].kind, VariantKind::gcode);
  EXPECT_EQ((*v)[6].gcode_path, "out/prusa.gcode");
  EXPECT_TRUE((*v)[6].settings.empty());
}

TEST(CompareVariants, GcodeOnlyWithLabels) {
  SweepSpec spec;
  spec.gcodes = {"a/part.gcode", "b/part.gcode"};
  auto v = expand_variants(spec);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(labels_of(*v), (std::vector<std::string>{"part", "part (2)"}));
  spec.labels = {"PrusaSlicer", "Cura"};
  v = expand_variants(spec);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(labels_of(*v), (std::vector<std::string>{"PrusaSlicer", "Cura"}));

  spec.labels = {"only one"};
  auto bad = expand_variants(spec);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::usage);
  EXPECT_NE(bad.error().message.find("2 variants"), std::string::npos) << bad.error().message;
  spec.labels = {"same", "same"};
  EXPECT_FALSE(expand_variants(spec).ok());
}

TEST(CompareVariants, NothingToVaryIsOneDefaultVariant) {
  auto v = expand_variants(SweepSpec{});
  ASSERT_TRUE(v.ok());
  ASSERT_EQ(v->size(), 1u);
  EXPECT_EQ((*v)[0].label, "printtwin defaults");
}

TEST(CompareVariants, RejectsRepeatedAxesAndHugeSweeps) {
  SweepSpec spec;
  spec.axes = {*parse_sweep_axis("layer_height=0.1,0.2"), *parse_sweep_axis("layer-height=0.3")};
  EXPECT_FALSE(expand_variants(spec).ok());
  spec.axes.clear();
  for (int a = 0; a < 5; ++a) {
    SweepAxis axis;
    axis.key = "k" + std::to_string(a);
    for (int i = 0; i < 7; ++i) axis.values.push_back(std::to_string(i));
    spec.axes.push_back(axis);
  }
  auto r = expand_variants(spec);  // 7^5 = 16807 > 10000
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::usage);
}

TEST(CompareShards, RoundRobinCoversEveryVariantOnce) {
  const int count = 11;
  for (int n : {1, 2, 3, 4, 11, 16}) {
    std::vector<int> seen(count, 0);
    for (int k = 0; k < n; ++k) {
      auto idx = shard_indices(count, k, n);
      ASSERT_TRUE(idx.ok());
      for (int i : *idx) {
        EXPECT_EQ(i % n, k);
        ++seen[static_cast<std::size_t>(i)];
      }
      // Shares differ in size by at most one.
      EXPECT_LE(static_cast<int>(idx->size()), (count + n - 1) / n);
      EXPECT_GE(static_cast<int>(idx->size()), count / n);
    }
    for (int s : seen) EXPECT_EQ(s, 1) << "n=" << n;
  }
  EXPECT_EQ(*shard_indices(8, 1, 3), (std::vector<int>{1, 4, 7}));
  EXPECT_FALSE(shard_indices(8, 3, 3).ok());
  EXPECT_FALSE(shard_indices(8, -1, 3).ok());
  EXPECT_FALSE(shard_indices(8, 0, 0).ok());
}

// ---------------------------------------------------------------- Pareto

TEST(ComparePareto, HandMadeFront) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // (print time s, RMS mm)
  const std::vector<std::pair<double, double>> pts = {
      {600, 0.30},   // 0 fastest: optimal
      {1200, 0.20},  // 1 optimal
      {900, 0.25},   // 2 optimal (between 0 and 1)
      {1500, 0.20},  // 3 same RMS as 1 but slower: dominated
      {1800, 0.10},  // 4 most accurate: optimal
      {700, 0.35},   // 5 slower and worse than 0: dominated
      {1200, 0.20},  // 6 duplicate of 1: not dominated by it, optimal
      {600, 0.31},   // 7 same time as 0, worse RMS: dominated
      {nan, 0.01},   // 8 not a number: never optimal
      {2400, 0.12},  // 9 slower and worse than 4: dominated
  };
  const auto front = pareto_front(pts);
  const std::vector<bool> expected = {true,  true, true,  false, true,
                                      false, true, false, false, false};
  EXPECT_EQ(front, expected);

  // Brute-force definition agrees on the finite points.
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (std::isnan(pts[i].first)) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < pts.size(); ++j) {
      if (std::isnan(pts[j].first)) continue;
      const bool le = pts[j].first <= pts[i].first && pts[j].second <= pts[i].second;
      const bool lt = pts[j].first < pts[i].first || pts[j].second < pts[i].second;
      dominated |= le && lt;
    }
    EXPECT_EQ(front[i], !dominated) << i;
  }
}

TEST(ComparePareto, RandomSetsMatchBruteForce) {
  std::uint64_t state = 12345;
  auto next = [&] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>((state >> 33) % 50);  // coarse values: many ties
  };
  for (int round = 0; round < 200; ++round) {
    std::vector<std::pair<double, double>> pts(1 + round % 17);
    for (auto& p : pts) p = {next(), next()};
    const auto front = pareto_front(pts);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      bool dominated = false;
      for (const auto& q : pts)
        dominated |= q.first <= pts[i].first && q.second <= pts[i].second &&
                     (q.first < pts[i].first || q.second < pts[i].second);
      ASSERT_EQ(front[i], !dominated) << "round " << round << " point " << i;
    }
  }
}

TEST(ComparePareto, MarksOnlyVariantsThatRan) {
  const CompareResult r = hand_made_result();
  // time:  3600 2500 1900 1300 2000  —
  // RMS:   .045 .058 .075 .110 .083  —   (variant 4, the G-code, is beaten by 2)
  std::vector<bool> pareto;
  for (const auto& v : r.variants) pareto.push_back(v.pareto);
  EXPECT_EQ(pareto, (std::vector<bool>{true, true, true, true, false, false}));
  EXPECT_NEAR(r.variants[0].rms_mm, std::sqrt((0.04 * 0.04 + 0.05 * 0.05) / 2), 1e-12);
}

// ---------------------------------------------------------------- JSON, merge, manifest

TEST(CompareJson, RoundTripsEveryField) {
  const CompareResult r = hand_made_result();
  const std::string text = compare_json(r);
  auto back = parse_compare_json(text, "compare.json");
  ASSERT_TRUE(back.ok()) << back.error().describe();
  EXPECT_EQ(compare_json(*back), text);
  ASSERT_EQ(back->variants.size(), r.variants.size());
  for (std::size_t i = 0; i < r.variants.size(); ++i) {
    const auto& a = r.variants[i];
    const auto& b = back->variants[i];
    EXPECT_EQ(a.variant, b.variant);
    EXPECT_EQ(a.ran, b.ran);
    EXPECT_EQ(a.error, b.error);
    EXPECT_NEAR(a.print_time_s, b.print_time_s, 1e-6);
    EXPECT_NEAR(a.rms_mm, b.rms_mm, 1e-6);
    EXPECT_NEAR(a.mesh_to_deposit.slope_rms_mm, b.mesh_to_deposit.slope_rms_mm, 1e-6);
    EXPECT_EQ(a.gates.size(), b.gates.size());
    EXPECT_EQ(a.pareto, b.pareto);
    EXPECT_EQ(a.top_regions.size(), b.top_regions.size());
  }
  EXPECT_EQ(back->part.bbox_mm, r.part.bbox_mm);
  EXPECT_EQ(back->verify.gates.max_rms_mm, r.verify.gates.max_rms_mm);
  EXPECT_FALSE(back->verify.gates.max_excess_mm.has_value());
}

TEST(CompareJson, BadInputNamesTheKey) {
  std::string text = compare_json(hand_made_result());
  const auto at = text.find("\"print_time_s\": ");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 16, "\"print_time_s\": \"slow\", \"x\": ");
  auto r = parse_compare_json(text, "share.json");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::bad_input);
  EXPECT_EQ(r.error().file, "share.json");
  EXPECT_NE(r.error().message.find("variants[0].print_time_s"), std::string::npos)
      << r.error().message;

  EXPECT_FALSE(parse_compare_json("{", "x.json").ok());
  auto wrong = parse_compare_json(R"({"schema":"printtwin.check","schema_version":1})", "x.json");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("printtwin.compare"), std::string::npos);
}

// Splits a whole result into the shares `--variant k --of n` would have written.
std::vector<CompareResult> split(const CompareResult& whole, int n) {
  std::vector<CompareResult> shares;
  for (int k = 0; k < n; ++k) {
    CompareResult s = whole;
    s.shard = std::make_pair(k, n);
    s.variants.clear();
    const std::vector<int> share = shard_indices(whole.variant_count, k, n).value();
    for (int i : share) {
      VariantResult v = whole.variants[static_cast<std::size_t>(i)];
      v.pareto = false;  // a share marks its own front; the merge recomputes it
      s.variants.push_back(v);
    }
    mark_pareto(s.variants);
    // Through the file format, as --merge reads them.
    shares.push_back(*parse_compare_json(compare_json(s), "share"));
  }
  return shares;
}

std::string without_timing(std::string json) {
  json =
      std::regex_replace(json, std::regex(R"re("run_time_s": [0-9.e+-]+)re"), "\"run_time_s\": 0");
  json =
      std::regex_replace(json, std::regex(R"re("(shared_s|total_s)": [0-9.e+-]+)re"), "\"$1\": 0");
  return json;
}

TEST(CompareMerge, SharesMergeIntoTheSameTable) {
  const CompareResult whole = hand_made_result();
  for (int n : {1, 2, 3, 4, 6, 9}) {
    auto shares = split(whole, n);
    // Order of the files does not matter.
    std::reverse(shares.begin(), shares.end());
    auto merged = merge_compare_results(shares);
    ASSERT_TRUE(merged.ok()) << merged.error().describe();
    EXPECT_FALSE(merged->shard.has_value());
    EXPECT_EQ(without_timing(compare_json(*merged)), without_timing(compare_json(whole)))
        << "n=" << n;
  }
  // Share 1 of 2 alone: variants 1, 3, 5; its own front (1 and 3) differs from the whole's.
  auto shares = split(whole, 2);
  std::vector<bool> pareto;
  for (const auto& v : shares[1].variants) pareto.push_back(v.pareto);
  EXPECT_EQ(pareto, (std::vector<bool>{true, true, false}));
}

TEST(CompareMerge, RejectsMismatchedOrIncompleteShares) {
  const CompareResult whole = hand_made_result();
  auto shares = split(whole, 3);

  auto missing = merge_compare_results({shares[0], shares[2]});
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("2 of 6 variants are missing (indices 1, 4)"),
            std::string::npos)
      << missing.error().message;
  auto partial = merge_compare_results({shares[0], shares[2]}, /*require_complete=*/false);
  ASSERT_TRUE(partial.ok());
  EXPECT_EQ(partial->variants.size(), 4u);

  auto other_plan = shares;
  other_plan[1].plan_id = std::string(64, 'c');
  auto r = merge_compare_results(other_plan);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("another sweep"), std::string::npos);

  auto other_mesh = shares;
  other_mesh[2].part.sha256 = std::string(64, 'd');
  EXPECT_FALSE(merge_compare_results(other_mesh).ok());

  auto relabelled = shares;
  relabelled.push_back(shares[0]);
  relabelled.back().variants[0].variant.label = "something else";
  EXPECT_FALSE(merge_compare_results(relabelled).ok());

  // The same share uploaded twice (a retried job) is fine.
  auto twice = shares;
  twice.push_back(shares[1]);
  auto ok = merge_compare_results(twice);
  ASSERT_TRUE(ok.ok()) << ok.error().describe();
  EXPECT_EQ(ok->variants.size(), 6u);

  EXPECT_FALSE(merge_compare_results({}).ok());
}

TEST(ComparePlanManifest, RoundTripAndIdentity) {
  ComparePlan plan;
  plan.mesh_path = "samples/models/curved_part.stl";
  plan.mesh_sha256 = std::string(64, 'e');
  plan.verify.gates.tolerance_mm = 0.25;
  plan.verify.voxel_mm = 0.1;
  plan.verify.place_mm = Vec3(110, 110, 0);
  SweepSpec spec;
  spec.axes = {*parse_sweep_axis("layer_height=0.1,0.2"),
               *parse_sweep_axis("fill_density=15%,40%")};
  spec.gcodes = {"prusa.gcode"};
  plan.variants = *expand_variants(spec);

  const std::string text = compare_plan_json(plan);
  auto back = parse_compare_plan(text, "plan.json");
  ASSERT_TRUE(back.ok()) << back.error().describe();
  EXPECT_EQ(back->variants, plan.variants);
  EXPECT_EQ(back->mesh_path, plan.mesh_path);
  EXPECT_NEAR(back->verify.gates.tolerance_mm, 0.25, 1e-12);
  ASSERT_TRUE(back->verify.place_mm.has_value());
  EXPECT_NEAR(back->verify.place_mm->x(), 110, 1e-12);
  EXPECT_EQ(compare_plan_id(*back), compare_plan_id(plan));

  // The id ignores where the mesh lives, not what it is or what runs.
  ComparePlan moved = plan;
  moved.mesh_path = "/ci/checkout/samples/models/curved_part.stl";
  EXPECT_EQ(compare_plan_id(moved), compare_plan_id(plan));
  ComparePlan other = plan;
  other.variants[1].settings.back().second = "41%";
  EXPECT_NE(compare_plan_id(other), compare_plan_id(plan));
  ComparePlan tighter = plan;
  tighter.verify.gates.tolerance_mm = 0.1;
  EXPECT_NE(compare_plan_id(tighter), compare_plan_id(plan));

  // An edited manifest is refused.
  std::string edited = text;
  const auto at = edited.find("\"0.2\"");
  ASSERT_NE(at, std::string::npos);
  edited.replace(at, 5, "\"0.25\"");
  auto refused = parse_compare_plan(edited, "plan.json");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("edited"), std::string::npos);
}

}  // namespace
}  // namespace printtwin
