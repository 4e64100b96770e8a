#pragma once
// Union-find with path halving, shared by region clustering and registration.
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

namespace printtwin::detail {

/// Sets are represented by their smallest member, so results do not depend on merge order.
struct DisjointSets {
  std::vector<std::uint32_t> parent;
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0U); }
  std::uint32_t find(std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace printtwin::detail
