// Checks 1–9 of mesh_import.h and their repairs, on the polygon soup.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

// CGAL stays in this file: its headers cost seconds per translation unit.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <fmt/format.h>

#include "common/error.h"
#include "geometry/mesh_import_detail.h"

namespace plumage::geometry::mesh_import_detail {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
// Exact predicates: "collinear" and "these triangles cross" must not depend on round-off.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;

// Defects named in a rejection message; the report lists more.
constexpr std::size_t kMaxNamedInMessage = 8;

Point point(const Soup& soup, std::uint32_t v) {
    const Vec3& p = soup.positions[v];
    return Point(p.x(), p.y(), p.z());
}

// ---------------------------------------------------------------------------------------
// Checks and repairs.

bool is_blocking(MeshDefectKind kind, bool repair) {
    switch (kind) {
        case MeshDefectKind::border_edge:
        case MeshDefectKind::non_manifold_edge:
        case MeshDefectKind::non_manifold_vertex:
        case MeshDefectKind::non_orientable:
        case MeshDefectKind::self_intersection:
            return true;
        case MeshDefectKind::degenerate_face:
        case MeshDefectKind::inconsistent_orientation:
        case MeshDefectKind::inward_orientation:
        case MeshDefectKind::shading_normal_flipped:
            return !repair;
        case MeshDefectKind::duplicate_vertex:
        case MeshDefectKind::isolated_vertex:
        case MeshDefectKind::shading_normals_dropped:
            return false;
    }
    return true;
}

// Keeps the triangles whose flag is set, with their sources.
void keep_triangles(Soup& soup, const std::vector<char>& keep) {
    std::size_t out = 0;
    for (std::size_t t = 0; t < soup.triangles.size(); ++t) {
        if (!keep[t]) continue;
        soup.triangles[out] = soup.triangles[t];
        soup.face_ordinal[out] = soup.face_ordinal[t];
        soup.face_line[out] = soup.face_line[t];
        ++out;
    }
    soup.triangles.resize(out);
    soup.face_ordinal.resize(out);
    soup.face_line.resize(out);
}

// 1. Bit-identical positions. Returns, per vertex, whether it was merged into another.
std::vector<char> merge_duplicates(Soup& soup, const Names& names, bool repair,
                                   Reporter& reporter) {
    const std::size_t n = soup.positions.size();
    std::vector<std::uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    const auto& p = soup.positions;
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        if (p[a].x() != p[b].x()) return p[a].x() < p[b].x();
        if (p[a].y() != p[b].y()) return p[a].y() < p[b].y();
        if (p[a].z() != p[b].z()) return p[a].z() < p[b].z();
        return a < b;
    });
    std::vector<std::uint32_t> target(n);
    std::iota(target.begin(), target.end(), 0u);
    std::vector<char> merged(n, 0);
    std::optional<std::string> normal_conflict;
    for (std::size_t i = 1, keep = 0; i < n; ++i) {
        const std::uint32_t v = order[i];
        if (p[v] != p[order[keep]]) {
            keep = i;
            continue;
        }
        const std::uint32_t kept = order[keep];  // the first in file order of the group
        reporter.add(MeshDefectKind::duplicate_vertex, soup.vertex_ordinal[v],
                     soup.vertex_ordinal[kept], soup.vertex_line[v], repair, [&] {
                         return fmt::format("{} is at the same position as {}, {} µm: {}",
                                            soup.vertex_name(names, v),
                                            soup.vertex_name(names, kept), format_vec(p[v]),
                                            repair ? "merged" : "not merged (repair is off)");
                     });
        if (!repair) continue;
        target[v] = kept;
        merged[v] = 1;
        if (!soup.normals.empty() && !normal_conflict &&
            (soup.normals[v] - soup.normals[kept]).norm() > 1e-6) {
            normal_conflict = fmt::format(
                "{} and {} share a position but not a shading normal "
                "(a crease)",
                soup.vertex_name(names, v), soup.vertex_name(names, kept));
        }
    }
    if (repair) {
        for (Triangle& t : soup.triangles) {
            for (std::uint32_t& v : t) v = target[v];
        }
    }
    if (normal_conflict) drop_normals(soup, reporter, *normal_conflict);
    return merged;
}

// 2. Triangles with a repeated vertex or collinear vertices (exact predicate).
void remove_degenerate(Soup& soup, const Names& names, bool repair, Reporter& reporter) {
    std::vector<char> keep(soup.triangles.size(), 1);
    for (std::size_t t = 0; t < soup.triangles.size(); ++t) {
        const auto [a, b, c] = soup.triangles[t];
        const char* reason = nullptr;
        if (a == b || b == c || a == c) {
            reason = "uses one vertex twice";
        } else if (CGAL::collinear(point(soup, a), point(soup, b), point(soup, c))) {
            reason = "has zero area (its vertices are collinear)";
        }
        if (reason == nullptr) continue;
        keep[t] = 0;
        reporter.add(MeshDefectKind::degenerate_face, soup.face_ordinal[t], 0, soup.face_line[t],
                     repair, [&] {
                         return fmt::format(
                             "{} {}: {}", soup.face_name(names, t), reason,
                             repair ? "removed" : "expected a triangle of non-zero area");
                     });
    }
    // Removed even without repair: the later checks need a clean surface to say anything,
    // and import rejects the mesh anyway.
    keep_triangles(soup, keep);
}

// 3. Vertices in no triangle. Merged duplicates are removed silently (already reported).
void remove_isolated(Soup& soup, const Names& names, bool repair, const std::vector<char>& merged,
                     Reporter& reporter) {
    const std::size_t n = soup.positions.size();
    std::vector<char> used(n, 0);
    for (const Triangle& t : soup.triangles) {
        for (const std::uint32_t v : t) used[v] = 1;
    }
    for (std::uint32_t v = 0; v < n; ++v) {
        if (used[v] || merged[v]) continue;
        reporter.add(MeshDefectKind::isolated_vertex, soup.vertex_ordinal[v], 0,
                     soup.vertex_line[v], repair, [&] {
                         return fmt::format("{} is in no face: {}", soup.vertex_name(names, v),
                                            repair ? "removed" : "left (repair is off)");
                     });
    }
    if (!repair) return;
    std::vector<std::uint32_t> index(n, 0);
    std::uint32_t out = 0;
    for (std::uint32_t v = 0; v < n; ++v) {
        if (!used[v]) continue;
        index[v] = out;
        soup.positions[out] = soup.positions[v];
        if (!soup.normals.empty()) soup.normals[out] = soup.normals[v];
        soup.vertex_ordinal[out] = soup.vertex_ordinal[v];
        soup.vertex_line[out] = soup.vertex_line[v];
        ++out;
    }
    soup.positions.resize(out);
    if (!soup.normals.empty()) soup.normals.resize(out);
    soup.vertex_ordinal.resize(out);
    soup.vertex_line.resize(out);
    for (Triangle& t : soup.triangles) {
        for (std::uint32_t& v : t) v = index[v];
    }
}

class UnionFind final {
public:
    explicit UnionFind(std::size_t n) : parent_(n) {
        std::iota(parent_.begin(), parent_.end(), std::size_t{0});
    }
    std::size_t find(std::size_t x) {
        while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
        return x;
    }
    void unite(std::size_t a, std::size_t b) { parent_[find(a)] = find(b); }

private:
    std::vector<std::size_t> parent_;
};

struct Topology {
    std::vector<std::uint32_t> component;  // per triangle
    std::size_t components = 0;
    bool closed = true;
};

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// A triangle's edge from corner k to corner k + 1, keyed by its vertices in order.
struct HalfEdge {
    std::uint32_t lo, hi, face;
    std::uint8_t k;  // the edge from corner k to corner k + 1
    bool forward;    // lo → hi
};

// Every triangle's three edges, sorted so that the faces sharing an edge are adjacent.
std::vector<HalfEdge> sorted_half_edges(const Soup& soup) {
    const std::size_t faces = soup.triangles.size();
    std::vector<HalfEdge> half_edges;
    half_edges.reserve(3 * faces);
    for (std::size_t f = 0; f < faces; ++f) {
        const Triangle& t = soup.triangles[f];
        for (std::uint8_t k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3];
            half_edges.push_back(
                {std::min(a, b), std::max(a, b), static_cast<std::uint32_t>(f), k, a < b});
        }
    }
    std::sort(half_edges.begin(), half_edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
        return std::tie(x.lo, x.hi, x.face, x.k) < std::tie(y.lo, y.hi, y.face, y.k);
    });
    return half_edges;
}

// What the edges say: across each manifold edge (per face corner k) the neighbouring face and
// whether it runs the edge the same way (which consistent winding forbids); the corners joined
// through manifold edges (a vertex's fans); the vertices on non-manifold edges.
struct EdgeIncidence {
    explicit EdgeIncidence(const Soup& soup)
        : corners(3 * soup.triangles.size()),
          neighbour(3 * soup.triangles.size(), kNone),
          same_direction(3 * soup.triangles.size(), 0),
          on_bad_edge(soup.positions.size(), 0) {}
    UnionFind corners;
    std::vector<std::uint32_t> neighbour;
    std::vector<char> same_direction;
    std::vector<char> on_bad_edge;
    bool closed = true;
};

// 4–5. Border and non-manifold edges reported; the manifold ones joined.
EdgeIncidence edge_incidence(const Soup& soup, const Names& names, bool require_closed,
                             Reporter& reporter) {
    const std::vector<HalfEdge> half_edges = sorted_half_edges(soup);
    auto corner = [&](std::uint32_t f, std::uint32_t v) {
        const Triangle& t = soup.triangles[f];
        return 3 * std::size_t{f} + (t[0] == v ? 0 : t[1] == v ? 1 : 2);
    };
    auto edge_name = [&](const HalfEdge& h) {
        return fmt::format("edge between {} and {}", soup.vertex_name(names, h.lo),
                           soup.vertex_name(names, h.hi));
    };
    EdgeIncidence e(soup);
    for (std::size_t i = 0; i < half_edges.size();) {
        std::size_t j = i + 1;
        while (j < half_edges.size() && half_edges[j].lo == half_edges[i].lo &&
               half_edges[j].hi == half_edges[i].hi) {
            ++j;
        }
        const HalfEdge& h = half_edges[i];
        if (j - i == 1) {
            e.closed = false;
            if (require_closed) {
                reporter.add(MeshDefectKind::border_edge, soup.face_ordinal[h.face], 0,
                             soup.face_line[h.face], false, [&] {
                                 return fmt::format(
                                     "border edge: {} of {} has no other face, the mesh is open "
                                     "there (a missing face?): expected a closed surface "
                                     "(require_closed = false accepts open films)",
                                     edge_name(h), soup.face_name(names, h.face));
                             });
            }
        } else if (j - i > 2) {
            e.on_bad_edge[h.lo] = e.on_bad_edge[h.hi] = 1;
            reporter.add(
                MeshDefectKind::non_manifold_edge, soup.face_ordinal[h.face],
                soup.face_ordinal[half_edges[i + 1].face], soup.face_line[h.face], false, [&] {
                    std::string list;
                    for (std::size_t k = i; k < j && k < i + 4; ++k) {
                        list += (k > i ? ", " : "") + soup.face_name(names, half_edges[k].face);
                    }
                    if (j - i > 4) list += ", ...";
                    return fmt::format(
                        "non-manifold edge: {} is shared by {} faces ({}): "
                        "expected at most 2",
                        edge_name(h), j - i, list);
                });
        } else {
            const HalfEdge& g = half_edges[i + 1];
            e.corners.unite(corner(h.face, h.lo), corner(g.face, h.lo));
            e.corners.unite(corner(h.face, h.hi), corner(g.face, h.hi));
            const bool same = h.forward == g.forward;
            e.neighbour[3 * std::size_t{h.face} + h.k] = g.face;
            e.neighbour[3 * std::size_t{g.face} + g.k] = h.face;
            e.same_direction[3 * std::size_t{h.face} + h.k] = same;
            e.same_direction[3 * std::size_t{g.face} + g.k] = same;
        }
        i = j;
    }
    return e;
}

// 5. A manifold vertex has one fan of faces around it, joined through its edges.
void report_non_manifold_vertices(const Soup& soup, const Names& names, EdgeIncidence& e,
                                  Reporter& reporter) {
    const std::size_t faces = soup.triangles.size();
    std::vector<std::pair<std::uint32_t, std::size_t>> vertex_fans;
    vertex_fans.reserve(3 * faces);
    for (std::size_t c = 0; c < 3 * faces; ++c) {
        vertex_fans.emplace_back(soup.triangles[c / 3][c % 3], e.corners.find(c));
    }
    std::sort(vertex_fans.begin(), vertex_fans.end());
    vertex_fans.erase(std::unique(vertex_fans.begin(), vertex_fans.end()), vertex_fans.end());
    for (std::size_t i = 0; i < vertex_fans.size();) {
        std::size_t j = i + 1;
        while (j < vertex_fans.size() && vertex_fans[j].first == vertex_fans[i].first) ++j;
        const std::uint32_t v = vertex_fans[i].first;
        // (A vertex on a non-manifold edge is already named by that edge.)
        if (j - i > 1 && !e.on_bad_edge[v]) {
            reporter.add(MeshDefectKind::non_manifold_vertex, soup.vertex_ordinal[v], 0,
                         soup.vertex_line[v], false, [&] {
                             return fmt::format(
                                 "non-manifold vertex: the faces around {} form {} separate fans "
                                 "(surfaces touching at a point): expected one",
                                 soup.vertex_name(names, v), j - i);
                         });
        }
        i = j;
    }
}

// 6. One edge-connected component's winding from its seed face (breadth-first; parity[f] says
// whether f must flip to agree with the seed), its minority flipped. False when it is
// non-orientable (reported).
bool orient_component(Soup& soup, const Names& names, bool repair, const EdgeIncidence& e,
                      std::uint32_t seed, Topology& topology, std::vector<char>& parity,
                      Reporter& reporter) {
    const auto id = static_cast<std::uint32_t>(topology.components++);
    std::vector<std::uint32_t> members{seed};
    topology.component[seed] = id;
    bool orientable = true;
    for (std::size_t m = 0; m < members.size(); ++m) {
        const std::uint32_t f = members[m];
        for (std::size_t k = 0; k < 3; ++k) {
            const std::uint32_t g = e.neighbour[3 * std::size_t{f} + k];
            if (g == kNone) continue;
            const char expected = parity[f] ^ e.same_direction[3 * std::size_t{f} + k];
            if (topology.component[g] == kNone) {
                topology.component[g] = id;
                parity[g] = expected;
                members.push_back(g);
            } else if (parity[g] != expected) {
                orientable = false;
            }
        }
    }
    if (!orientable) {
        reporter.add(MeshDefectKind::non_orientable, soup.face_ordinal[seed], 0,
                     soup.face_line[seed], false, [&] {
                         return fmt::format(
                             "non-orientable surface: the surface containing {} is one-sided, "
                             "like a Möbius strip: expected a two-sided surface",
                             soup.face_name(names, seed));
                     });
        return false;
    }
    std::size_t odd = 0;
    for (const std::uint32_t f : members) odd += parity[f];
    // Flip the smaller class: the faces that disagree with most of their surface.
    const char flip = odd <= members.size() - odd ? 1 : 0;
    for (const std::uint32_t f : members) {
        if (parity[f] != flip) continue;
        reporter.add(
            MeshDefectKind::inconsistent_orientation, soup.face_ordinal[f], 0, soup.face_line[f],
            repair, [&] {
                return fmt::format(
                    "{} winds against its neighbours (inconsistent orientation): {}",
                    soup.face_name(names, f),
                    repair ? "flipped" : "expected the winding of its neighbours (repair is off)");
            });
        std::swap(soup.triangles[f][1], soup.triangles[f][2]);
    }
    return true;
}

// 4–6. Edge incidence: borders, non-manifold edges and vertices, then a consistent winding
// per edge-connected component (breadth-first, flipping the minority). Returns nullopt when
// a blocking defect was found.
std::optional<Topology> check_topology(Soup& soup, const Names& names, bool repair,
                                       bool require_closed, Reporter& reporter,
                                       const MeshReport& report) {
    EdgeIncidence incidence = edge_incidence(soup, names, require_closed, reporter);
    report_non_manifold_vertices(soup, names, incidence, reporter);
    if (blocking_count(report, true) > 0) return std::nullopt;
    const std::size_t faces = soup.triangles.size();
    Topology topology;
    topology.closed = incidence.closed;
    topology.component.assign(faces, kNone);
    std::vector<char> parity(faces, 0);
    bool orientable = true;
    for (std::uint32_t seed = 0; seed < faces; ++seed) {
        if (topology.component[seed] != kNone) continue;
        if (!orient_component(soup, names, repair, incidence, seed, topology, parity, reporter))
            orientable = false;
    }
    if (!orientable) return std::nullopt;
    return topology;
}

// The soup as a CGAL halfedge mesh: face i is triangle i; vertices in no triangle are left
// out (orient_to_bound_a_volume crashes on isolated vertices, which the soup keeps when
// repair is off), so soup_vertex maps the mesh's vertices back.
struct CgalMesh {
    SurfaceMesh mesh;
    std::vector<std::uint32_t> soup_vertex;
};

CgalMesh to_surface_mesh(const Soup& soup) {
    // Invariant of check_topology: CGAL can hold the soup as a halfedge mesh.
    PLUMAGE_CHECK(PMP::is_polygon_soup_a_polygon_mesh(soup.triangles),
                  "a soup that passed the topology checks must be a polygon mesh");
    CgalMesh out;
    std::vector<std::uint32_t> mesh_vertex(soup.positions.size(), kNone);
    for (const Triangle& t : soup.triangles) {
        for (const std::uint32_t v : t) {
            if (mesh_vertex[v] != kNone) continue;
            mesh_vertex[v] = static_cast<std::uint32_t>(out.soup_vertex.size());
            out.soup_vertex.push_back(v);
        }
    }
    SurfaceMesh& mesh = out.mesh;
    mesh.reserve(static_cast<SurfaceMesh::size_type>(out.soup_vertex.size()),
                 static_cast<SurfaceMesh::size_type>(3 * soup.triangles.size() / 2 + 3),
                 static_cast<SurfaceMesh::size_type>(soup.triangles.size()));
    for (const std::uint32_t v : out.soup_vertex) mesh.add_vertex(point(soup, v));
    for (std::size_t t = 0; t < soup.triangles.size(); ++t) {
        const Triangle& tri = soup.triangles[t];
        const auto f = mesh.add_face(SurfaceMesh::Vertex_index(mesh_vertex[tri[0]]),
                                     SurfaceMesh::Vertex_index(mesh_vertex[tri[1]]),
                                     SurfaceMesh::Vertex_index(mesh_vertex[tri[2]]));
        PLUMAGE_CHECK(f != SurfaceMesh::null_face() && f.idx() == t,
                      "Surface_mesh faces must follow the soup's triangle order");
    }
    return out;
}

// 7. Pairs of faces that cross (CGAL's box-intersection filter, exact predicates).
void check_self_intersections(const Soup& soup, const SurfaceMesh& mesh, const Names& names,
                              Reporter& reporter) {
    std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
    PMP::self_intersections(mesh, std::back_inserter(pairs));
    // Name each pair of file faces once (a polygon is several triangles).
    std::set<std::pair<std::size_t, std::size_t>> named;
    for (const auto& [fa, fb] : pairs) {
        std::size_t a = fa.idx(), b = fb.idx();
        if (soup.face_ordinal[a] > soup.face_ordinal[b]) std::swap(a, b);
        if (!named.emplace(soup.face_ordinal[a], soup.face_ordinal[b]).second) continue;
        reporter.add(MeshDefectKind::self_intersection, soup.face_ordinal[a], soup.face_ordinal[b],
                     soup.face_line[a], false, [&] {
                         return fmt::format(
                             "self-intersection: {} and {} cross: expected a surface that does "
                             "not pass through itself",
                             soup.face_name(names, a), soup.face_name(names, b));
                     });
    }
}

// 8. Closed meshes: each shell oriented so that the mesh bounds a volume (outer shells
// outward, shells nested inside them inward, and so on), by CGAL's nesting analysis.
void orient_volume(Soup& soup, CgalMesh& cgal, const Topology& topology, const Names& names,
                   bool repair, Reporter& reporter) {
    SurfaceMesh& mesh = cgal.mesh;
    PMP::orient_to_bound_a_volume(mesh);
    std::vector<std::size_t> flipped(topology.components, 0);
    std::vector<std::uint32_t> first(topology.components, kNone);
    std::vector<std::size_t> size(topology.components, 0);
    for (std::size_t t = 0; t < soup.triangles.size(); ++t) {
        const auto h = mesh.halfedge(SurfaceMesh::Face_index(static_cast<std::uint32_t>(t)));
        const std::uint32_t v0 = cgal.soup_vertex[mesh.target(h).idx()];
        const std::uint32_t v1 = cgal.soup_vertex[mesh.target(mesh.next(h)).idx()];
        Triangle& tri = soup.triangles[t];
        const std::size_t at = tri[0] == v0 ? 0 : tri[1] == v0 ? 1 : 2;
        const std::uint32_t c = topology.component[t];
        ++size[c];
        if (first[c] == kNone) first[c] = static_cast<std::uint32_t>(t);
        if (tri[(at + 1) % 3] != v1) {
            std::swap(tri[1], tri[2]);
            ++flipped[c];
        }
    }
    for (std::size_t c = 0; c < topology.components; ++c) {
        if (flipped[c] == 0) continue;
        // A shell is flipped as a whole: its winding was already made consistent.
        PLUMAGE_CHECK(flipped[c] == size[c], "orient_to_bound_a_volume flips whole shells");
        reporter.add(MeshDefectKind::inward_orientation, soup.face_ordinal[first[c]], 0,
                     soup.face_line[first[c]], repair, [&] {
                         return fmt::format(
                             "the closed shell containing {} ({} triangles) is inside-out (its "
                             "faces wind clockwise seen from the side they should face): {}",
                             soup.face_name(names, first[c]), size[c],
                             repair ? "flipped"
                                    : "expected counter-clockwise winding seen from outside "
                                      "(repair is off)");
                     });
    }
}

// 9. A shading normal must lie on the side its faces face, or shading turns black.
void check_shading_normals(Soup& soup, const Names& names, bool repair, Reporter& reporter) {
    if (soup.normals.empty()) return;
    std::vector<Vec3> face_sum(soup.positions.size(), Vec3::Zero());
    for (const Triangle& t : soup.triangles) {
        const Vec3& a = soup.positions[t[0]];
        // Twice the area vector: an area-weighted average direction.
        const Vec3 area = (soup.positions[t[1]] - a).cross(soup.positions[t[2]] - a);
        for (const std::uint32_t v : t) face_sum[v] += area;
    }
    for (std::uint32_t v = 0; v < soup.positions.size(); ++v) {
        if (soup.normals[v].dot(face_sum[v]) >= 0.0) continue;
        reporter.add(MeshDefectKind::shading_normal_flipped, soup.vertex_ordinal[v], 0,
                     soup.vertex_line[v], repair, [&] {
                         return fmt::format(
                             "{}: shading normal {} points against its faces: {}",
                             soup.vertex_name(names, v), format_vec(soup.normals[v]),
                             repair ? "flipped" : "expected it on their side (repair is off)");
                     });
        soup.normals[v] = -soup.normals[v];
    }
}

}  // namespace

bool collinear(const Soup& soup, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    return CGAL::collinear(point(soup, a), point(soup, b), point(soup, c));
}

void drop_normals(Soup& soup, Reporter& reporter, const std::string& reason) {
    soup.normals.clear();
    reporter.add(MeshDefectKind::shading_normals_dropped, 0, 0, 0, true, [&] {
        return fmt::format("{}: shading normals dropped, the tracer uses face normals", reason);
    });
}

std::size_t blocking_count(const MeshReport& report, bool repair) {
    std::size_t total = 0;
    for (std::size_t k = 0; k < kMeshDefectKinds; ++k) {
        if (is_blocking(static_cast<MeshDefectKind>(k), repair)) total += report.counts[k];
    }
    return total;
}

// Runs checks 1–9 on the soup, repairing it in place where `repair` (and, so that later
// checks can see past them, removing degenerate faces and fixing windings even without;
// callers that do not repair do not use the soup afterwards).
void check_soup(Soup& soup, const Names& names, bool repair, bool require_closed,
                MeshReport& report) {
    Reporter reporter(report);
    report.vertices_read = soup.positions.size();
    report.faces_read = soup.faces_read;
    const std::vector<char> merged = merge_duplicates(soup, names, repair, reporter);
    remove_degenerate(soup, names, repair, reporter);
    if (soup.triangles.empty()) return;
    remove_isolated(soup, names, repair, merged, reporter);
    const std::optional<Topology> topology =
        check_topology(soup, names, repair, require_closed, reporter, report);
    if (!topology) return;
    report.components = topology->components;
    report.closed = topology->closed;
    CgalMesh cgal = to_surface_mesh(soup);
    check_self_intersections(soup, cgal.mesh, names, reporter);
    if (blocking_count(report, true) > 0) return;
    // An open mesh has no inside to point away from: its components keep the winding of
    // their majority.
    if (topology->closed) orient_volume(soup, cgal, *topology, names, repair, reporter);
    check_shading_normals(soup, names, repair, reporter);
    report.triangles_out = soup.triangles.size();
}

[[noreturn]] void reject(const MeshReport& report, const Names& names, bool repair) {
    const std::size_t total = blocking_count(report, repair);
    std::string message =
        fmt::format("{}: mesh rejected, {} defect{} that {} {}:", names.file(), total,
                    total == 1 ? "" : "s", total == 1 ? "is" : "are",
                    repair ? "not safely repairable" : "not repaired (repair is off)");
    std::size_t named = 0;
    for (const MeshDefect& d : report.defects) {
        if (!is_blocking(d.kind, repair)) continue;
        if (named++ == kMaxNamedInMessage) break;
        message += "\n  " + d.message;
    }
    if (total > kMaxNamedInMessage) {
        message += fmt::format("\n  ... and {} more", total - kMaxNamedInMessage);
    }
    throw InputError(message);
}

}  // namespace plumage::geometry::mesh_import_detail
