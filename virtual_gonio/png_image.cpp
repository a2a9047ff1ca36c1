#include "virtual_gonio/png_image.h"

#include <unistd.h>

#include <fmt/format.h>
#include <stb/stb_image_write.h>

#include "common/error.h"

namespace plumage::record {

RgbImage::RgbImage(int w, int h) : width(w), height(h) {
    PLUMAGE_CHECK(w > 0 && h > 0, fmt::format("image size {} x {}", w, h));
    pixels.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 0);
}

void RgbImage::set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
    const std::size_t i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                           static_cast<std::size_t>(x)) * 3;
    pixels[i] = r;
    pixels[i + 1] = g;
    pixels[i + 2] = b;
}

void write_png(const std::filesystem::path& path, const RgbImage& image) {
    std::filesystem::path temporary = path;
    temporary += fmt::format(".partial-{}", ::getpid());
    if (stbi_write_png(temporary.c_str(), image.width, image.height, 3, image.pixels.data(),
                       image.width * 3) == 0) {
        std::error_code ignored;
        std::filesystem::remove(temporary, ignored);
        throw IoError(fmt::format("cannot write PNG '{}'", path.string()));
    }
    std::error_code error;
    std::filesystem::rename(temporary, path, error);
    if (error) {
        std::filesystem::remove(temporary, error);
        throw IoError(fmt::format("cannot rename PNG into place: '{}'", path.string()));
    }
}

}  // namespace plumage::record
