// HDR and spectral images as OpenEXR, written beside the PNGs the studies show: the values the
// PNG was drawn from, in their units, without exposure, clipping or the sRGB curve.
//
// Layout (Fichet, Pacanowski & Wilkie 2021, "An OpenEXR Layout for Spectral Images", JCGT
// 10(3), spectralLayoutVersion 1.0):
//  - one part per image; a file of several images (a comparison, fingerprint panels, BTF
//    tiles) is a multi-part file whose parts are named by SpectralImage::name;
//  - every channel float32 (PixelType FLOAT), scan lines, ZIP compression (lossless): a
//    value is exactly static_cast<float> of the double the instrument computed;
//  - pixel (x, y) = (column, row), row 0 at the top, as in the PNG; data window = display
//    window = [0, width − 1] × [0, height − 1];
//  - spectral channels, one per wavelength, named by the vacuum wavelength with a comma as
//    decimal mark (the dot separates layers) and the fewest digits that give it back:
//      `S0.<λ>nm`  Quantity::emissive: a radiometric quantity per wavelength (Fichet's Stokes
//                  S0 channels; ours are not radiances: see `units`);
//      `T.<λ>nm`   Quantity::reflective: a dimensionless reflectance or transmittance;
//    e.g. `S0.450nm`, `S0.532,5nm`;
//  - extra spectral layers, the same channel names behind a prefix: `<layer>.S0.<λ>nm` (e.g.
//    `stderr.S0.450nm`, the standard error of `S0.450nm`; `lobe.R.S0.450nm`, one scattering
//    lobe's share). Readers of the layout that match channel names whole ignore them;
//  - `R`, `G`, `B`: the colour the PNG shows, before exposure and tone mapping: linear sRGB
//    (Rec. 709 primaries, D65 white: the `chromaticities` attribute) of the spectrum's XYZ under
//    D65 with the CIE 1931 2° observer (gonio::SpectrumToDisplay, display_colour.h), in the
//    spectral channels' units (a flat spectrum v gives R = G = B = v); out-of-gamut
//    components stay negative, nothing is clipped.
// Header attributes (strings unless said): `spectralLayoutVersion` ("1.0"), `units` (of the
// spectral and RGB channels, e.g. "1/sr"), `quantity` (what a value is), `description` (what
// the image is), `study`, `rgb` (the RGB rule above), `wavelengths_nm` (floatvector), and the
// image's own (SpectralImage::attributes), e.g. `scatterer`.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace plumage::gonio {

struct Scatterogram;
struct BtfRecord;
struct BrdfRecord;

struct SpectralImage {
    enum class Quantity { emissive, reflective };
    struct Layer {
        std::string prefix;          // e.g. "stderr", "lobe.R"
        std::vector<double> values;  // as `values`
    };

    std::string name = "image";  // the part's name
    int width = 0, height = 0;
    std::vector<double> wavelengths_nm;
    Quantity quantity = Quantity::emissive;
    std::string units;  // of the values, e.g. "1/sr"
    std::string quantity_description;
    std::string description;
    // Row-major [row][column][wavelength], row 0 at the top.
    std::vector<double> values;
    std::vector<Layer> layers;
    std::map<std::string, std::string> attributes;

    void validate() const;  // sizes, wavelengths increasing and positive
};

// The channel name of one wavelength: "S0.450nm", "T.532,5nm".
std::string spectral_channel_name(SpectralImage::Quantity quantity, double wavelength_nm);

// One image per part, in order; part names must differ. Written to a temporary name and
// renamed, like records (`.partial-<pid>`); IoError on failure, nothing left behind.
void write_spectral_exr(const std::filesystem::path& path, const std::vector<SpectralImage>& parts,
                        const std::string& study);

// A scatterogram (scatterometer.h) as an image: intensity per unit incident power in 1/sr, its
// standard error (`stderr`) and each lobe's share (`lobe.<name>`); 0 outside the disc.
SpectralImage scatterogram_exr_image(const Scatterogram& s, const std::string& name);
// A BRDF fingerprint (Filip et al. 2024, Fig. 7; goniometer.h brdf_fingerprint) of a
// light-major pair list: one pixel per pair, rows the `lights` light directions, columns the
// `views` view directions; the BRDF averaged over the detector cone (1/sr), its standard error
// and each lobe's share.
SpectralImage fingerprint_exr_image(const BrdfRecord& record, int lights, int views,
                                    const std::string& name);
// One (light, view) pair of a BTF record (btf.h): the BRDF of each pixel's patch area (1/sr),
// with its standard error.
SpectralImage btf_exr_image(const BtfRecord& record, std::size_t pair, const std::string& name);

}  // namespace plumage::gonio
