// Extrusion into air (see support.hpp).
#include "deposit/support.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "printtwin/io.hpp"

namespace printtwin::detail {

namespace {
constexpr double kRegionGapMm = 1.0;         // unsupported stretches this close: one finding
constexpr std::size_t kMaxClustered = 4000;  // beyond this, one finding per layer and kind
}  // namespace

void SupportTracker::check_bead(const Move& mv, const Vec3& a, const Vec3& b, const Vec2& n,
                                int samples, double h, double w, bool continues_path,
                                const HeightMap& map, DroopProbe* droop) {
  if (!continues_path) {
    close_stretch(false);
    path_has_support_ = false;
  }
  const double inv_voxel = 1.0 / voxel_;
  const int across = std::max(3, static_cast<int>(std::ceil(w * inv_voxel)));
  const double tol = 0.5 * h;
  const double step_mm = mv.xy_length_mm() / samples;
  offsets_.resize(static_cast<std::size_t>(across));
  for (int j = 0; j < across; ++j)
    offsets_[static_cast<std::size_t>(j)] = -0.5 * w + (j + 0.5) * w / across;
  // The samples across, in voxel units relative to the grid origin.
  for (double& s : offsets_) s *= inv_voxel;
  const HeightMapView view = map.view();
  const double nxv = n.x(), nyv = n.y();
  // A level bead's samples all have the start's height (a + t * 0 is a), so the rows they
  // need are found once.
  const bool level = a.z() == b.z();
  const int level_rows = level ? map.rows_reaching((a.z() - h) - tol) : 0;
  // A sample is supported when at least support_fraction of its points are held.
  const int enough = std::max(0, static_cast<int>(std::ceil(support_fraction_ * across - 1e-9)));
  for (int i = 0; i < samples; ++i) {
    const Vec3 q = a + ((i + 0.5) / samples) * (b - a);
    const double bottom = q.z() - h;
    const int need_rows = level ? level_rows : map.rows_reaching(bottom - tol);
    const bool supported = held_at_least(view, map.u(q.x()), map.v(q.y()), nxv, nyv,
                                         offsets_.data(), across, need_rows, enough);
    sample(mv, a, b, i, samples, step_mm, supported,
           supported || droop == nullptr ? Drop{} : droop->sample(i));
  }
}

void SupportTracker::sample(const Move& mv, const Vec3& a, const Vec3& b, int i, int samples,
                            double step_mm, bool supported, const Drop& drop) {
  if (supported) {
    close_stretch(true);
    path_has_support_ = true;
    return;
  }
  if (!active_) {
    active_ = true;
    open_ = UnsupportedStretch{};
    open_.layer = mv.layer;
    open_.first_line = mv.line;
    open_.start_mm = a + (static_cast<double>(i) / samples) * (b - a);
    open_.bridge = path_has_support_;
    open_.feature = mv.feature;
  }
  open_.last_line = mv.line;
  open_.end_mm = a + ((i + 1.0) / samples) * (b - a);
  open_.length_mm += step_mm;
  open_.drop_mm = std::max(open_.drop_mm, drop.mm);
  open_.falls = open_.falls || drop.kind == DropKind::fallen;
}

void SupportTracker::close_stretch(bool end_supported) {
  if (!active_) return;
  active_ = false;
  open_.bridge = open_.bridge && end_supported;
  unsupported_mm_ += open_.length_mm;
  if (open_.length_mm >= min_unsupported_mm_) stretches_.push_back(open_);
}

namespace {

/// Kinds of stretches, each its own finding: a bead held on one side, a bridge, and sparse
/// infill crossing the cells of the sparse infill below (normal, not deformed).
enum Kind { kCantilever = 0, kBridge = 1, kSparse = 2 };

int kind_of(const UnsupportedStretch& s) {
  return s.feature == Feature::sparse_infill ? kSparse : s.bridge ? kBridge : kCantilever;
}

struct Group {
  int layer;
  int kind;
  Box3 box;
  std::vector<const UnsupportedStretch*> items;
};

Box3 box_of(const UnsupportedStretch& s) {
  Box3 b;
  b.extend(s.start_mm);
  b.extend(s.end_mm);
  return b;
}

bool near(const Box3& a, const Box3& b) {
  return (a.min.array() - kRegionGapMm <= b.max.array()).all() &&
         (b.min.array() - kRegionGapMm <= a.max.array()).all();
}

/// Stretches of the same layer and kind whose boxes come near each other, in one group.
std::vector<Group> group_stretches(const std::vector<UnsupportedStretch>& stretches) {
  std::vector<Group> groups;
  std::size_t layer_begin = 0;  // first group of the current (layer, kind) run
  for (const auto& s : stretches) {
    const Box3 b = box_of(s);
    Group* target = nullptr;
    const std::size_t n = groups.size();
    for (std::size_t g = layer_begin; g < n; ++g) {
      if (groups[g].layer != s.layer || groups[g].kind != kind_of(s)) continue;
      if (n - layer_begin > kMaxClustered || near(groups[g].box, b)) {
        target = &groups[g];
        break;
      }
    }
    if (target == nullptr) {
      if (!groups.empty() && groups.back().layer != s.layer) layer_begin = groups.size();
      groups.push_back(Group{s.layer, kind_of(s), Box3{}, {}});
      target = &groups.back();
    }
    target->box.extend(b);
    target->items.push_back(&s);
  }
  // Merging may have made groups of one layer touch: merge until stable.
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t i = 0; i < groups.size() && !merged; ++i)
      for (std::size_t j = i + 1; j < groups.size() && groups[j].layer == groups[i].layer; ++j)
        if (groups[j].kind == groups[i].kind && near(groups[i].box, groups[j].box)) {
          groups[i].box.extend(groups[j].box);
          groups[i].items.insert(groups[i].items.end(), groups[j].items.begin(),
                                 groups[j].items.end());
          groups.erase(groups.begin() + static_cast<std::ptrdiff_t>(j));
          merged = true;
          break;
        }
  }
  std::stable_sort(groups.begin(), groups.end(), [](const Group& x, const Group& y) {
    if (x.layer != y.layer) return x.layer < y.layer;
    if (x.kind != y.kind) return x.kind < y.kind;
    return x.items.front()->first_line < y.items.front()->first_line;
  });
  return groups;
}

Finding finding_of(const Group& g) {
  double total = 0;
  const UnsupportedStretch* longest = g.items.front();
  Box3 extent;
  double drop = 0;
  bool falls = false;
  for (const auto* s : g.items) {
    total += s->length_mm;
    drop = std::max(drop, s->drop_mm);
    falls = falls || s->falls;
    if (s->length_mm > longest->length_mm) longest = s;
    extent.extend(s->start_mm);
    extent.extend(s->end_mm);
  }
  Finding f;
  static constexpr const char* kCodes[] = {"extrusion_into_air_cantilever",
                                           "extrusion_into_air_bridge",
                                           "extrusion_into_air_sparse_infill"};
  static constexpr const char* kWhat[] = {"cantilevered (held on one side)",
                                          "bridged (supported at both ends)",
                                          "sparse infill crossing the gaps of the infill below"};
  f.severity = g.kind == kCantilever ? Severity::warning : Severity::info;
  f.code = kCodes[g.kind];
  f.message = "layer " + std::to_string(g.layer) + ": " + std::to_string(g.items.size()) +
              " unsupported " + kWhat[g.kind] + " stretch" + (g.items.size() == 1 ? "" : "es") +
              ", " + format_fixed(total, 1) + " mm in total; longest " +
              format_fixed(longest->length_mm, 1) + " mm at G-code lines " +
              std::to_string(longest->first_line) + "-" + std::to_string(longest->last_line) +
              " (" + std::string(to_string(longest->feature)) + ")";
  if (g.kind == kSparse) {
    f.message += "; normal for sparse infill, which spans the cells below (not deformed)";
  } else {
    f.message +=
        std::string("; predicted to ") + (g.kind == kBridge ? "sag" : "droop") + " up to " +
        format_fixed(drop, 2) + " mm below its layer" +
        (drop >= 0.005 ? " (that much lower and rougher underside)" : " (no visible effect)");
    if (falls)
      f.message +=
          "; part of it is beyond the fall limit and falls onto what is below or dangles as a "
          "string";
  }
  f.position_mm = longest->start_mm;
  f.extent_mm = extent;
  f.line = longest->first_line;
  f.layer = g.layer;
  f.value = total;
  f.count = static_cast<long>(g.items.size());
  return f;
}

}  // namespace

std::vector<Finding> make_findings(const std::vector<UnsupportedStretch>& stretches) {
  std::vector<Finding> out;
  for (const auto& g : group_stretches(stretches)) out.push_back(finding_of(g));
  return out;
}

}  // namespace printtwin::detail
