// What the instrument figures of studies/plots.py draw, written by C++ into HDF5: the colour
// conversion (display_colour.h: D65, CIE 1931, one exposure) stays here, Python only draws.
//
// Every image is display sRGB as float in [0, 1] (the sRGB transfer curve applied; what
// display_bytes() would round to 8 bits), [row, column, rgb], row 0 at the top, beside its
// luminance Y in the record's units (1/sr: a luminance-weighted radiant intensity or BRDF, a
// flat spectrum of value v has Y = v). The exposure is one number per figure, stored as the
// luminance that maps to white (`white_luminance_per_sr`): images that are compared share it.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "sim/optics/colour.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/instrument_registry.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {

// display_bytes() without the rounding: exposure scales luminance, negative components clip
// to 0, over-range colours are scaled by their largest component, then the sRGB curve.
std::array<float, 3> display_srgb(const optics::Xyz& xyz, double exposure);

// The `scatterogram_comparison` figure's data, in the group `figure/` of `h5`: display sRGB
// and luminance of both scatterograms at one exposure (the brighter of the two peaks → white),
// the signed luminance difference simulation − model, and each pixel's ϑ and φ (degrees;
// NaN outside the disc) with the map convention as an attribute.
void write_scatterogram_figure(record::Hdf5Writer& h5, const gonio::Scatterogram& simulation,
                               const gonio::Scatterogram& model, const std::string& title);

// The `scatterogram_levels` figure's data, in the group `figure/` of `h5`: scatterograms of
// one instrument (size, wavelengths, beam) by different scatterers, each panel's display sRGB
// and luminance (`figure/panel<k>/`, its title and peak luminance as attributes) at one
// exposure (the brightest panel's peak → white), and each pixel's ϑ and φ as above.
struct ScatterogramPanel {
    std::string title;
    const gonio::Scatterogram* scatterogram = nullptr;
};
void write_scatterogram_panels(record::Hdf5Writer& h5, const std::string& title,
                               const std::vector<ScatterogramPanel>& panels);

// Fingerprints (Filip 2024 Fig. 7 layout: rows the light directions, columns the view
// directions) of records on the same light-major pair list, at one exposure for all panels
// (the brightest cell of any panel → white). Written to its own file at `path`.
struct FingerprintPanel {
    std::string title;
    const gonio::BrdfRecord* record = nullptr;
};
void write_fingerprint_figure(const std::filesystem::path& path, const std::string& title,
                              const std::vector<FingerprintPanel>& panels, int lights, int views);

// BTF images of the listed pairs (Filip 2024 Fig. 9: tiles in rows of 6) at one exposure (the
// brightest pixel of the tiles → white), with each tile's (θ_i, φ_i, θ_o, φ_o) and the patch
// size in µm. Written to its own file at `path`.
void write_btf_figure(const std::filesystem::path& path, const std::string& title,
                      const gonio::BtfRecord& btf, const std::vector<std::size_t>& pairs);

// A registered instrument's curves against wavelength (virtual_gonio/instrument_registry.h), each
// with its standard error: `wavelength_nm`, `curves/<k>/value`, `curves/<k>/standard_error`, the
// labels, the title and the y quantity as attributes. Written to its own file at `path`.
void write_instrument_curves_figure(const std::filesystem::path& path,
                                    const std::vector<double>& wavelengths_nm,
                                    const gonio::InstrumentResult& result);

}  // namespace plumage::studies
