// Mesh health: topology counts from sorted edge lists and union-find (no third-party code).
#include <algorithm>
#include <numeric>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"

namespace printtwin {

namespace detail {

Vec3 face_centroid(const Mesh& mesh, std::size_t f) {
  const auto& t = mesh.triangles[f];
  return (mesh.vertices_mm[t[0]] + mesh.vertices_mm[t[1]] + mesh.vertices_mm[t[2]]) / 3.0;
}

UnionFind::UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0U); }

EdgeTable build_edge_table(const Mesh& mesh, const std::vector<char>& skip_face) {
  EdgeTable table;
  const std::size_t nv = mesh.vertices_mm.size();
  const auto kept = [&](std::size_t f) { return skip_face.empty() || skip_face[f] == 0; };
  // Sorted by (lo, hi, face): half-edges are placed by lo with a counting sort in face order,
  // then each vertex's few half-edges are sorted by hi, stably (one face never holds an
  // undirected edge twice once repeated indices are skipped; if it did, both would sit
  // together in face order). A vertex has about six half-edges starting at it: insertion
  // sort, or a stable sort for a large fan.
  std::vector<std::uint32_t> start(nv + 1, 0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (!kept(f)) continue;
    const auto& t = mesh.triangles[f];
    for (int k = 0; k < 3; ++k) ++start[std::size_t{std::min(t[k], t[(k + 1) % 3])} + 1];
  }
  for (std::size_t v = 1; v <= nv; ++v) start[v] += start[v - 1];
  table.half_edges.resize(start[nv]);
  std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (!kept(f)) continue;
    const auto& t = mesh.triangles[f];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k];
      const std::uint32_t b = t[(k + 1) % 3];
      const std::uint32_t lo = std::min(a, b);
      table.half_edges[next[lo]++] = {lo, std::max(a, b), static_cast<std::uint32_t>(f), a < b};
    }
  }
  const auto by_hi = [](const HalfEdge& x, const HalfEdge& y) { return x.hi < y.hi; };
  for (std::size_t v = 0; v < nv; ++v) {
    const auto first = table.half_edges.begin() + start[v];
    const auto last = table.half_edges.begin() + start[v + 1];
    if (last - first < 2) continue;  // nothing to order (and no first + 1 past an empty run)
    if (last - first > 32) {
      std::stable_sort(first, last, by_hi);
      continue;
    }
    for (auto i = first + 1; i < last; ++i) {
      const HalfEdge e = *i;
      auto j = i;
      for (; j > first && e.hi < (j - 1)->hi; --j) *j = *(j - 1);
      *j = e;
    }
  }
  table.groups.reserve(table.half_edges.size() / 2 + 1);
  for (std::size_t i = 0; i < table.half_edges.size();) {
    std::size_t j = i + 1;
    while (j < table.half_edges.size() && table.half_edges[j].lo == table.half_edges[i].lo &&
           table.half_edges[j].hi == table.half_edges[i].hi)
      ++j;
    table.groups.push_back({i, j});
    i = j;
  }
  return table;
}

std::vector<char> duplicate_or_index_degenerate_faces(const Mesh& mesh, std::size_t* duplicates) {
  const std::size_t n = mesh.triangles.size();
  const std::size_t nv = mesh.vertices_mm.size();
  std::vector<char> skip(n, 0);
  // Faces by their lowest vertex (a counting sort in face order), then within each vertex's
  // few faces every face whose vertex set an earlier face already has is a repeat: the
  // first face stays, its repeats are marked.
  const auto sorted = [&](std::size_t f) {
    auto t = mesh.triangles[f];
    std::sort(t.begin(), t.end());
    return t;
  };
  std::vector<std::uint32_t> start(nv + 1, 0);
  for (std::size_t f = 0; f < n; ++f) {
    const auto& t = mesh.triangles[f];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      skip[f] = 1;
      continue;
    }
    ++start[std::size_t{std::min({t[0], t[1], t[2]})} + 1];
  }
  for (std::size_t v = 1; v <= nv; ++v) start[v] += start[v - 1];
  std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint32_t>> keys(start[nv]);
  std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < n; ++f) {
    if (skip[f] != 0) continue;
    const auto t = sorted(f);
    keys[next[t[0]]++] = {t, static_cast<std::uint32_t>(f)};
  }
  std::size_t dup = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    const auto first = keys.begin() + start[v];
    const auto last = keys.begin() + start[v + 1];
    if (last - first < 2) continue;  // no repeat possible (and no first + 1 past an empty run)
    if (last - first > 32) {         // a large fan: sorted by vertex set, faces ascending in a set
      std::sort(first, last);
      for (auto i = first + 1; i < last; ++i)
        if (i->first == (i - 1)->first) {
          skip[i->second] = 1;
          ++dup;
        }
      continue;
    }
    for (auto i = first + 1; i < last; ++i)
      for (auto j = first; j < i; ++j)
        if (j->first == i->first) {
          skip[i->second] = 1;
          ++dup;
          break;
        }
  }
  if (duplicates != nullptr) *duplicates = dup;
  return skip;
}

ShellTable compute_shells(const Mesh& mesh, const std::vector<char>& skip, const EdgeTable& edges) {
  const std::size_t nf = mesh.triangles.size();
  UnionFind uf(nf);
  std::vector<char> open_face(nf, 0);
  for (const auto& [begin, end] : edges.groups) {
    for (std::size_t i = begin + 1; i < end; ++i)
      uf.unite(edges.half_edges[begin].face, edges.half_edges[i].face);
    if (end - begin != 2)
      for (std::size_t i = begin; i < end; ++i) open_face[edges.half_edges[i].face] = 1;
  }
  ShellTable table;
  table.shell_of_face.assign(nf, UINT32_MAX);
  std::vector<std::uint32_t> index_of_root(nf, UINT32_MAX);
  const Box3 box = bounding_box(mesh);
  const Vec3 ref = box.empty() ? Vec3::Zero() : box.center();
  for (std::size_t f = 0; f < nf; ++f) {
    if (!skip.empty() && skip[f] != 0) continue;
    const std::uint32_t root = uf.find(static_cast<std::uint32_t>(f));
    if (index_of_root[root] == UINT32_MAX) {
      index_of_root[root] = static_cast<std::uint32_t>(table.shells.size());
      table.shells.emplace_back();
    }
    table.shell_of_face[f] = index_of_root[root];
    Shell& s = table.shells[index_of_root[root]];
    const auto& t = mesh.triangles[f];
    const Vec3 a = mesh.vertices_mm[t[0]] - ref;
    const Vec3 b = mesh.vertices_mm[t[1]] - ref;
    const Vec3 c = mesh.vertices_mm[t[2]] - ref;
    s.six_volume += a.dot(b.cross(c));
    s.open = s.open || open_face[f] != 0;
    for (auto v : t) s.box.extend(mesh.vertices_mm[v]);
  }
  // A closed shell with negative volume is a cavity when another, positive shell's box
  // holds it; otherwise it is inside out.
  for (std::size_t i = 0; i < table.shells.size(); ++i) {
    Shell& si = table.shells[i];
    if (si.open || si.six_volume >= 0) continue;
    bool cavity = false;
    for (std::size_t j = 0; j < table.shells.size() && !cavity; ++j) {
      const Shell& sj = table.shells[j];
      cavity = j != i && sj.six_volume > 0 && sj.box.contains(si.box.min) &&
               sj.box.contains(si.box.max) && !(sj.box == si.box);
    }
    si.inverted = !cavity;
  }
  return table;
}

std::size_t flip_inverted_shells(Mesh& mesh) {
  const std::vector<char> skip = duplicate_or_index_degenerate_faces(mesh, nullptr);
  const ShellTable table = compute_shells(mesh, skip, build_edge_table(mesh, skip));
  std::size_t flipped = 0;
  for (const auto& s : table.shells) flipped += s.inverted ? 1 : 0;
  if (flipped == 0) return 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const std::uint32_t s = table.shell_of_face[f];
    if (s != UINT32_MAX && table.shells[s].inverted)
      std::swap(mesh.triangles[f][1], mesh.triangles[f][2]);
  }
  return flipped;
}

}  // namespace detail

MeshHealth analyze_mesh_health(const Mesh& mesh) {
  using namespace detail;
  MeshHealth h;
  const std::size_t nf = mesh.triangles.size();
  h.triangles = nf;
  h.volume_mm3 = signed_volume_mm3(mesh);
  h.area_mm2 = surface_area_mm2(mesh);

  std::vector<char> used(mesh.vertices_mm.size(), 0);
  for (const auto& t : mesh.triangles)
    for (auto v : t) used[v] = 1;
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v] != 0) {
      ++h.vertices;
      h.bbox_mm.extend(mesh.vertices_mm[v]);
    }

  for (std::size_t f = 0; f < nf; ++f)
    if (is_degenerate_face(mesh, f)) {
      if (h.degenerate_faces == 0) h.first_degenerate_face_mm = face_centroid(mesh, f);
      ++h.degenerate_faces;
    }

  // Duplicates and faces with a repeated index stay out of the edge analysis: each is
  // reported once as such, not again as the non-manifold or open edges it would cause.
  const std::vector<char> skip = duplicate_or_index_degenerate_faces(mesh, &h.duplicate_faces);
  const EdgeTable edges = build_edge_table(mesh, skip);

  UnionFind corners(3 * nf);  // fans around each vertex, joined across manifold edges
  auto corner_of = [&](std::uint32_t f, std::uint32_t v) {
    const auto& t = mesh.triangles[f];
    const std::uint32_t k = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
    return 3 * f + k;
  };
  auto midpoint = [&](const HalfEdge& e) {
    return Vec3(0.5 * (mesh.vertices_mm[e.lo] + mesh.vertices_mm[e.hi]));
  };
  for (const auto& [begin, end] : edges.groups) {
    const HalfEdge& e0 = edges.half_edges[begin];
    const std::size_t count = end - begin;
    if (count == 1) {
      if (h.boundary_edges == 0) h.first_boundary_edge_mm = midpoint(e0);
      ++h.boundary_edges;
    } else if (count == 2) {
      const HalfEdge& e1 = edges.half_edges[begin + 1];
      corners.unite(corner_of(e0.face, e0.lo), corner_of(e1.face, e0.lo));
      corners.unite(corner_of(e0.face, e0.hi), corner_of(e1.face, e0.hi));
      if (e0.forward == e1.forward) {
        if (h.inconsistent_edges == 0) h.first_inconsistent_edge_mm = midpoint(e0);
        ++h.inconsistent_edges;
      }
    } else {
      if (h.non_manifold_edges == 0) h.first_non_manifold_edge_mm = midpoint(e0);
      ++h.non_manifold_edges;
    }
  }
  h.closed = h.boundary_edges == 0 && h.non_manifold_edges == 0;

  // Non-manifold vertices: more than one fan of faces around the vertex.
  std::vector<std::uint32_t> first_root(mesh.vertices_mm.size(), UINT32_MAX);
  std::vector<char> flagged(mesh.vertices_mm.size(), 0);
  for (std::size_t f = 0; f < nf; ++f) {
    if (skip[f] != 0) continue;
    for (std::uint32_t k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.triangles[f][k];
      const std::uint32_t root = corners.find(static_cast<std::uint32_t>(3 * f + k));
      if (first_root[v] == UINT32_MAX) {
        first_root[v] = root;
      } else if (first_root[v] != root && flagged[v] == 0) {
        flagged[v] = 1;
        if (h.non_manifold_vertices == 0) h.first_non_manifold_vertex_mm = mesh.vertices_mm[v];
        ++h.non_manifold_vertices;
      }
    }
  }

  const ShellTable shells_table = compute_shells(mesh, skip, edges);
  h.shells = shells_table.shells.size();
  for (const auto& s : shells_table.shells) h.shell_bbox_mm.push_back(s.box);
  h.shell_faces.assign(shells_table.shells.size(), 0);
  for (auto sh : shells_table.shell_of_face)
    if (sh != UINT32_MAX) ++h.shell_faces[sh];
  for (const auto& s : shells_table.shells) h.inverted_shells += s.inverted ? 1 : 0;
  return h;
}

}  // namespace printtwin
