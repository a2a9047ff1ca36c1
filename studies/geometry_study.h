// `plumage geometry STUDY`: builds the geometry a study file describes and writes it
// (PLY meshes, instance transforms, VDB volumes) with a PNG preview of a cross-section
// and a Markdown report, into <results_root>/<name>/ (replaced atomically).
//
// Study file schema (TOML; unknown keys are errors; angles in degrees):
//   name = "rock_dove_row"            # results folder (default: the file's stem)
//   [geometry]
//   kind = "barbule_row"              # barbule_row | barb_patch | spongy_channel |
//                                     # spongy_spheres | mesh | vdb
//   [geometry.tessellation]           # max_chord_um, max_normal_error_deg
//   [geometry.cell]                   # barbule_row: b, phi0_deg, phi1_deg, theta_d_deg,
//                                     # semi_major_um, cell_length_um, profile,
//                                     # film_thickness_um, melanin_depth_um
//   [geometry.row]                    # barbule_row: H, mu_deg, barbules, cells_per_barbule,
//                                     # jitter_phi_deg, jitter_theta_deg, seed
//   [geometry.vane]                   # barb_patch: Padrón-Griffe's parameters with the
//                                     # authors' meanings (studies/README.md, "Padrón-Griffe
//                                     # parameters"): barb_width_um, barb_axis_ratio, ...
//   [geometry.patch]                  # barb_patch: length_um, barbs
//   [geometry.spongy]                 # spongy_*: keratin_fraction, box_um, voxel_um, seed,
//                                     # length_scale_um, shell_relative_width (channel);
//                                     # sphere_radius_um, min_separation_diameters (spheres)
//   [geometry.mesh]                   # mesh: file (relative to the study file), scale_to_um,
//                                     # require_closed, repair; vdb: file, grid
// Examples: studies/geometry/*.toml.
#pragma once

#include <filesystem>
#include <string>

namespace plumage::studies {

struct GeometryStudyResult {
    std::filesystem::path output_dir;
    std::string kind;
    std::size_t triangles = 0;  // in the stored unit meshes (before instancing)
    std::size_t instances = 0;
    std::size_t memory_bytes = 0;
    double wall_seconds = 0.0;
};

GeometryStudyResult run_geometry_study(const std::filesystem::path& study_file,
                                       const std::filesystem::path& results_root);
// The same from the file's text; relative paths inside it are relative to source's folder.
GeometryStudyResult run_geometry_study(const std::string& text, const std::filesystem::path& source,
                                       const std::filesystem::path& results_root);

}  // namespace plumage::studies
