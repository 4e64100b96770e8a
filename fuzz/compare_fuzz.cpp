// libFuzzer target: compare's inputs. The first byte picks what the rest is read as: a
// manifest (parse_compare_plan), a share's compare.json (parse_compare_json), or --vary /
// --set text (parse_sweep_axis, parse_setting_kv, then expand_variants). A manifest that
// parses must write itself out as a manifest that parses back to the same text.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "printtwin/compare.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  switch (data[0] % 3) {
    case 0: {
      auto plan = printtwin::parse_compare_plan(text, "fuzz-manifest.json");
      if (!plan) return plan.error().message.empty() ? (__builtin_trap(), 0) : 0;
      const std::string json = printtwin::compare_plan_json(*plan);
      auto again = printtwin::parse_compare_plan(json, "round-trip.json");
      if (!again || printtwin::compare_plan_json(*again) != json) __builtin_trap();
      return 0;
    }
    case 1: {
      auto result = printtwin::parse_compare_json(text, "fuzz-compare.json");
      if (!result) return result.error().message.empty() ? (__builtin_trap(), 0) : 0;
      (void)printtwin::compare_json(*result);
      return 0;
    }
    default: {
      // One --vary per line; a line with '=' but no ',' is also tried as --set.
      printtwin::SweepSpec spec;
      std::size_t pos = 0;
      while (pos <= text.size() && spec.axes.size() < 4) {
        const std::size_t nl = text.find('\n', pos);
        const std::string_view line =
            text.substr(pos, nl == std::string_view::npos ? text.size() - pos : nl - pos);
        if (auto axis = printtwin::parse_sweep_axis(line)) spec.axes.push_back(std::move(*axis));
        if (auto kv = printtwin::parse_setting_kv(line))
          spec.common_settings.push_back(std::move(*kv));
        if (nl == std::string_view::npos) break;
        pos = nl + 1;
      }
      (void)printtwin::expand_variants(spec);
      return 0;
    }
  }
}
