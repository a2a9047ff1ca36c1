#include "virtual_gonio/exr_image.h"

#include <unistd.h>

#include <algorithm>
#include <exception>
#include <set>
#include <span>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFloatVectorAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfMultiPartOutputFile.h>
#include <OpenEXR/ImfOutputPart.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <fmt/format.h>

#include "common/error.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/display_colour.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::gonio {
namespace {

const char* kRgbRule =
    "linear sRGB (Rec. 709 primaries, D65 white) of the spectrum's XYZ under D65, CIE 1931 2 deg "
    "observer, white-balanced on the image's wavelength grid (virtual_gonio/display_colour.h); "
    "in the spectral channels' units, no exposure, no clipping (negative: out of gamut)";

// One channel's float32 plane.
struct Plane {
    std::string name;
    std::vector<float> data;
};

std::vector<Plane> planes_of(const SpectralImage& image) {
    const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
    const std::size_t nl = image.wavelengths_nm.size();
    std::vector<Plane> planes;
    // R, G, B from the spectra.
    const SpectrumToDisplay display(image.wavelengths_nm);
    for (const char* c : {"R", "G", "B"}) planes.push_back({c, std::vector<float>(pixels)});
    for (std::size_t p = 0; p < pixels; ++p) {
        const optics::Rgb rgb = optics::linear_srgb_from_xyz(
            display.xyz(std::span<const double>(image.values.data() + p * nl, nl)));
        for (std::size_t c = 0; c < 3; ++c) planes[c].data[p] = static_cast<float>(rgb[c]);
    }
    auto spectral = [&](const std::string& prefix, const std::vector<double>& values) {
        for (std::size_t k = 0; k < nl; ++k) {
            Plane plane{prefix + spectral_channel_name(image.quantity, image.wavelengths_nm[k]),
                        std::vector<float>(pixels)};
            for (std::size_t p = 0; p < pixels; ++p)
                plane.data[p] = static_cast<float>(values[p * nl + k]);
            planes.push_back(std::move(plane));
        }
    };
    spectral("", image.values);
    for (const SpectralImage::Layer& layer : image.layers)
        spectral(layer.prefix + ".", layer.values);
    return planes;
}

Imf::Header header_of(const SpectralImage& image, const std::vector<Plane>& planes,
                      const std::string& study) {
    Imf::Header h(image.width, image.height);
    h.compression() = Imf::ZIP_COMPRESSION;
    h.setName(image.name);
    h.setType(Imf::SCANLINEIMAGE);
    for (const Plane& plane : planes) h.channels().insert(plane.name, Imf::Channel(Imf::FLOAT));
    Imf::addChromaticities(h, Imf::Chromaticities());  // Rec. 709 primaries, D65 white
    auto text = [&h](const std::string& key, const std::string& value) {
        h.insert(key, Imf::StringAttribute(value));
    };
    text("spectralLayoutVersion", "1.0");
    text("units", image.units);
    text("quantity", image.quantity_description);
    text("description", image.description);
    text("study", study);
    text("rgb", kRgbRule);
    std::vector<float> wavelengths(image.wavelengths_nm.begin(), image.wavelengths_nm.end());
    h.insert("wavelengths_nm", Imf::FloatVectorAttribute(wavelengths));
    for (const auto& [key, value] : image.attributes) text(key, value);
    return h;
}

}  // namespace

void SpectralImage::validate() const {
    PLUMAGE_CHECK(width > 0 && height > 0,
                  fmt::format("EXR image '{}': {} x {}", name, width, height));
    PLUMAGE_CHECK(!wavelengths_nm.empty(), fmt::format("EXR image '{}': no wavelengths", name));
    for (std::size_t k = 0; k < wavelengths_nm.size(); ++k) {
        PLUMAGE_CHECK(
            wavelengths_nm[k] > 0.0 && (k == 0 || wavelengths_nm[k] > wavelengths_nm[k - 1]),
            fmt::format("EXR image '{}': wavelengths must increase", name));
    }
    const std::size_t size =
        static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * wavelengths_nm.size();
    PLUMAGE_CHECK(values.size() == size,
                  fmt::format("EXR image '{}': {} values, expected {}", name, values.size(), size));
    for (const Layer& layer : layers) {
        PLUMAGE_CHECK(!layer.prefix.empty() && layer.values.size() == size,
                      fmt::format("EXR image '{}': layer '{}' of {} values", name, layer.prefix,
                                  layer.values.size()));
    }
}

std::string spectral_channel_name(SpectralImage::Quantity quantity, double wavelength_nm) {
    std::string number = fmt::format("{}", wavelength_nm);  // shortest that reads back
    std::replace(number.begin(), number.end(), '.', ',');
    return fmt::format("{}.{}nm", quantity == SpectralImage::Quantity::emissive ? "S0" : "T",
                       number);
}

void write_spectral_exr(const std::filesystem::path& path, const std::vector<SpectralImage>& parts,
                        const std::string& study) {
    PLUMAGE_CHECK(!parts.empty(), "an EXR file needs an image");
    std::set<std::string> names;
    for (const SpectralImage& image : parts) {
        image.validate();
        PLUMAGE_CHECK(names.insert(image.name).second,
                      fmt::format("EXR '{}': two images named '{}'", path.string(), image.name));
    }
    std::vector<std::vector<Plane>> planes;
    std::vector<Imf::Header> headers;
    for (const SpectralImage& image : parts) {
        planes.push_back(planes_of(image));
        headers.push_back(header_of(image, planes.back(), study));
    }
    std::filesystem::path temporary = path;
    temporary += fmt::format(".partial-{}", ::getpid());
    try {
        // Scoped: the file is complete once the writer is destroyed.
        Imf::MultiPartOutputFile file(temporary.c_str(), headers.data(),
                                      static_cast<int>(headers.size()));
        for (std::size_t i = 0; i < parts.size(); ++i) {
            Imf::OutputPart part(file, static_cast<int>(i));
            Imf::FrameBuffer frame;
            const std::size_t x_stride = sizeof(float);
            const std::size_t y_stride = x_stride * static_cast<std::size_t>(parts[i].width);
            for (Plane& plane : planes[i]) {
                frame.insert(plane.name,
                             Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(plane.data.data()),
                                        x_stride, y_stride));
            }
            part.setFrameBuffer(frame);
            part.writePixels(parts[i].height);
        }
    } catch (const std::exception& e) {
        std::error_code ignored;
        std::filesystem::remove(temporary, ignored);
        throw IoError(fmt::format("cannot write EXR '{}': {}", path.string(), e.what()));
    }
    std::error_code error;
    std::filesystem::rename(temporary, path, error);
    if (error) {
        std::filesystem::remove(temporary, error);
        throw IoError(fmt::format("cannot rename EXR into place: '{}'", path.string()));
    }
}

SpectralImage scatterogram_exr_image(const Scatterogram& s, const std::string& name) {
    SpectralImage image;
    image.name = name;
    image.width = image.height = s.config.image_size;
    image.wavelengths_nm = s.config.wavelengths_nm;
    image.units = "1/sr";
    image.quantity_description =
        "radiant intensity per unit incident power, I = dP/domega / P_in, per wavelength";
    image.description =
        "scatterogram (virtual_gonio/scatterometer.h): the upper hemisphere as an azimuthal "
        "equidistant map, u right, v up in [-1, 1], theta = 90 deg * hypot(u, v), phi = atan2(v, "
        "u) from +x (the barb axis) towards +y; row 0 at the top; 0 outside the disc";
    image.values = s.intensity;
    if (!s.standard_error.empty()) image.layers.push_back({"stderr", s.standard_error});
    const std::size_t size = s.intensity.size();
    for (std::size_t l = 0; l < s.lobes.size() && s.lobe_intensity.size() >= (l + 1) * size; ++l) {
        const auto first = s.lobe_intensity.begin() + static_cast<std::ptrdiff_t>(l * size);
        image.layers.push_back(
            {"lobe." + s.lobes[l],
             std::vector<double>(first, first + static_cast<std::ptrdiff_t>(size))});
    }
    image.attributes["scatterer"] = s.scatterer;
    image.attributes["layers"] =
        "stderr: standard error of the intensity; lobe.<name>: the intensity of that lobe";
    return image;
}

SpectralImage fingerprint_exr_image(const BrdfRecord& record, int lights, int views,
                                    const std::string& name) {
    const std::size_t pairs = static_cast<std::size_t>(lights) * static_cast<std::size_t>(views);
    PLUMAGE_CHECK(
        lights > 0 && views > 0 && record.config.pairs.size() == pairs,
        fmt::format("fingerprint {} x {} of {} pairs", lights, views, record.config.pairs.size()));
    SpectralImage image;
    image.name = name;
    image.width = views;
    image.height = lights;
    image.wavelengths_nm = record.config.wavelengths_nm;
    image.units = "1/sr";
    image.quantity_description = "BRDF averaged over the detector cone, per wavelength";
    image.description =
        "BRDF fingerprint (Filip et al. 2024, Fig. 7): one pixel per (light, view) pair of a "
        "light-major pair list, row = light direction, column = view direction (pair = row * "
        "width + column, as in the record's /instrument/angles_deg)";
    image.values = record.value;
    if (!record.standard_error.empty()) image.layers.push_back({"stderr", record.standard_error});
    const std::size_t size = record.value.size();
    for (std::size_t l = 0; l < record.lobes.size() && record.lobe_values.size() >= (l + 1) * size;
         ++l) {
        const auto first = record.lobe_values.begin() + static_cast<std::ptrdiff_t>(l * size);
        image.layers.push_back(
            {"lobe." + record.lobes[l],
             std::vector<double>(first, first + static_cast<std::ptrdiff_t>(size))});
    }
    image.attributes["scatterer"] = record.scatterer;
    image.attributes["direction_set"] = record.config.direction_set;
    return image;
}

SpectralImage btf_exr_image(const BtfRecord& record, std::size_t pair, const std::string& name) {
    SpectralImage image;
    image.name = name;
    image.width = image.height = record.config.pixels;
    image.wavelengths_nm = record.config.wavelengths_nm;
    image.units = "1/sr";
    image.quantity_description = "BRDF of each pixel's patch area, per wavelength";
    const auto& p = record.config.pairs.at(pair);
    image.description = fmt::format(
        "BTF image (virtual_gonio/btf.h) of a {} um square patch, x right along the barb axis, y "
        "up, row 0 at the top; light direction ({:.6f}, {:.6f}, {:.6f}), view direction ({:.6f}, "
        "{:.6f}, {:.6f})",
        record.config.patch_size_um, p.wi.x(), p.wi.y(), p.wi.z(), p.wo.x(), p.wo.y(), p.wo.z());
    const std::size_t size =
        static_cast<std::size_t>(image.width) * image.height * image.wavelengths_nm.size();
    const auto first = static_cast<std::ptrdiff_t>(record.index(pair, 0, 0, 0));
    image.values.assign(record.value.begin() + first,
                        record.value.begin() + first + static_cast<std::ptrdiff_t>(size));
    if (!record.standard_error.empty()) {
        image.layers.push_back(
            {"stderr", std::vector<double>(record.standard_error.begin() + first,
                                           record.standard_error.begin() + first +
                                               static_cast<std::ptrdiff_t>(size))});
    }
    image.attributes["scatterer"] = record.scatterer;
    return image;
}

}  // namespace plumage::gonio
