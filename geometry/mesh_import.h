// Importing triangle meshes from PLY and OBJ files, and checking them before they reach
// the tracer. A mesh that leaks (open), branches (non-manifold), winds inconsistently or
// crosses itself has no well-defined inside, so the tracer would give light paths that
// enter a body and never leave it; those meshes are rejected here, with the file and the
// face or vertex named, rather than discovered as wrong spectra later.
//
// Formats:
//  - PLY, ascii or binary_little_endian: element `vertex` with x y z (float or double)
//    and optionally nx ny nz (shading normals); element `face` with a list property
//    `vertex_indices` (or `vertex_index`). Other elements and properties are skipped.
//  - OBJ: v, vn and f (v, v/vt, v//vn, v/vt/vn; negative indices count back from the
//    last vertex read). vt, vp, usemtl, mtllib, o, g, s and comments are ignored; any
//    other statement is an error.
//  The format follows the extension (.ply, .obj, any case).
//  Polygons are split into a triangle fan (from a corner whose fan has no zero-area
//  triangle) when convex and planar within kPolygonPlanarity; other polygons are rejected:
//  triangulate them in the modelling tool, which knows the intended surface.
//  Shading normals (PLY nx ny nz, OBJ vn) are normalised. They are dropped, and the drop
//  reported, when one position carries several (a flat-shaded export's creases) or only
//  some OBJ corners have one: the tracer then uses face normals, which is what a crease
//  means. Non-finite or zero normals are rejected.
//
// Naming in messages: the file; "line L" for OBJ and ASCII PLY statements; "vertex i" and
// "face i" for PLY elements (0-based, as PLY face lists count); OBJ vertices by the index
// face statements use (1-based) and OBJ faces by their line.
//
// Checks, in order (CGAL Polygon Mesh Processing for the geometric predicates):
//  1. duplicate vertices (bit-identical positions)       repair: merge
//  2. degenerate faces (repeated vertex, or collinear)   repair: remove
//  3. isolated vertices (in no face)                     repair: remove
//  4. border edges (open mesh)                           rejected unless require_closed = false
//  5. non-manifold edges (> 2 faces) and vertices (faces around a vertex form more
//     than one fan)                                      rejected
//  6. inconsistent orientation across an edge            repair: flip the minority
//     (non-orientable components are rejected)
//  7. self-intersections (pairs of faces that cross)     rejected
//  8. closed meshes: orientation that does not bound a volume (inside-out shells;
//     nested shells alternate)                           repair: flip the shell
//  9. shading normals pointing against their faces       repair: flip the normal
// With repair off, defects 1 and 3 are reported and left (harmless to the tracer, but
// faces that use both copies of a duplicate then meet at a seam of border edges);
// 2, 6, 8 and 9 are rejected. Self-intersections and open borders are never repaired:
// there is no safe guess at the intended surface.
//
// Units: positions are multiplied by scale_to_um, so the mesh returned is in micrometres.
// Conventions of the returned mesh are those of triangle_mesh.h (counter-clockwise seen
// from outside, unit shading normals or none).
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "geometry/triangle_mesh.h"

namespace plumage::geometry {

// Largest distance of a polygon's vertex from the polygon's mean plane, as a fraction of
// the polygon's bounding-box diagonal, for it to be fan-triangulated; exporters write
// float, so exact planarity cannot be asked for.
inline constexpr double kPolygonPlanarity = 1e-3;

struct MeshImportOptions {
    // false accepts open meshes: barbule films are one-sided surfaces with a border. The
    // other checks still run; only closed meshes are oriented to bound a volume.
    bool require_closed = true;
    bool repair = true;
    // Length of one file unit in micrometres (1e-3 for a file in nanometres).
    double scale_to_um = 1.0;

    // Throws InputError unless scale_to_um is finite and > 0.
    void validate() const;
};

enum class MeshDefectKind {
    duplicate_vertex,
    degenerate_face,
    isolated_vertex,
    border_edge,
    non_manifold_edge,
    non_manifold_vertex,
    non_orientable,
    inconsistent_orientation,
    self_intersection,
    inward_orientation,
    shading_normal_flipped,
    shading_normals_dropped,  // a position with several normals, or OBJ corners without
};
inline constexpr std::size_t kMeshDefectKinds = 12;

const char* to_string(MeshDefectKind kind);

struct MeshDefect {
    MeshDefectKind kind;
    // Face or vertex ordinal in the file (0-based; which one depends on kind). `other` is
    // the second face of a self-intersection or non-manifold edge, and the vertex that a
    // duplicate vertex duplicates.
    std::size_t index = 0;
    std::size_t other = 0;
    std::size_t line = 0;  // OBJ or ASCII PLY line of that face/vertex; 0 when none
    // Names the item (face or vertex, with its line) and what is expected; the file is
    // named by the InputError that rejects a mesh.
    std::string message;
    bool repaired = false;
};

struct MeshReport {
    // At most kMaxListedPerKind defects of each kind are listed; count() has them all (an
    // inside-out scan can have a million flipped shading normals).
    static constexpr std::size_t kMaxListedPerKind = 100;

    std::vector<MeshDefect> defects;
    std::array<std::size_t, kMeshDefectKinds> counts{};
    std::size_t vertices_read = 0;
    std::size_t faces_read = 0;  // polygons in the file
    std::size_t triangles_out = 0;
    std::size_t components = 0;  // edge-connected
    bool closed = false;

    std::size_t count(MeshDefectKind kind) const { return counts[static_cast<std::size_t>(kind)]; }
    bool clean() const;
    // One line per listed defect.
    std::string summary() const;
};

struct ImportedMesh {
    TriangleMesh mesh;
    MeshReport report;
};

// Reads, checks and (when options.repair) repairs a mesh. InputError for bad files and for
// rejected defects (the message lists them); IoError if the file cannot be read.
ImportedMesh import_mesh(const std::filesystem::path& path, const MeshImportOptions& options = {});

// import_mesh(path, options).mesh
TriangleMesh read_mesh(const std::filesystem::path& path, const MeshImportOptions& options = {});

// Runs the same checks on a mesh already in memory (a generator's output) without
// changing it or throwing for defects: every defect found is listed, unrepaired. Checks
// 7–9 run only when 4–6 found no border (if require_closed), non-manifold or
// non-orientable defect: they need a manifold, orientable surface. Names vertices and
// triangles by their index in `mesh`. InputError only for non-finite positions,
// out-of-range indices or a shading-normal count that is neither 0 nor one per vertex.
MeshReport check_mesh(const TriangleMesh& mesh, bool require_closed = true);

}  // namespace plumage::geometry
