#include "virtual_gonio/record/png_image.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>

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
                           static_cast<std::size_t>(x)) *
                          3;
    pixels[i] = r;
    pixels[i + 1] = g;
    pixels[i + 2] = b;
}

void RgbImage::fill(std::uint8_t r, std::uint8_t g, std::uint8_t b) {
    for (std::size_t i = 0; i < pixels.size(); i += 3) {
        pixels[i] = r;
        pixels[i + 1] = g;
        pixels[i + 2] = b;
    }
}

void RgbImage::draw_line(double x0, double y0, double x1, double y1,
                         const std::array<std::uint8_t, 3>& rgb) {
    // Sample the segment at half-pixel steps: simple, and thin lines stay connected.
    const double length = std::hypot(x1 - x0, y1 - y0);
    const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * length)));
    for (int i = 0; i <= steps; ++i) {
        const double t = static_cast<double>(i) / steps;
        const int x = static_cast<int>(std::lround(x0 + t * (x1 - x0)));
        const int y = static_cast<int>(std::lround(y0 + t * (y1 - y0)));
        if (x >= 0 && y >= 0 && x < width && y < height) set(x, y, rgb[0], rgb[1], rgb[2]);
    }
}

void RgbImage::fill_polygon(const std::vector<std::array<double, 2>>& polygon,
                            const std::array<std::uint8_t, 3>& rgb) {
    const std::size_t n = polygon.size();
    if (n < 3) return;
    for (int y = 0; y < height; ++y) {
        const double yc = y + 0.5;
        std::vector<double> xs;
        for (std::size_t i = 0; i < n; ++i) {
            const auto& a = polygon[i];
            const auto& b = polygon[(i + 1) % n];
            if ((a[1] <= yc) != (b[1] <= yc))
                xs.push_back(a[0] + (yc - a[1]) * (b[0] - a[0]) / (b[1] - a[1]));
        }
        std::sort(xs.begin(), xs.end());
        for (std::size_t k = 0; k + 1 < xs.size(); k += 2) {
            const int from = std::max(0, static_cast<int>(std::ceil(xs[k] - 0.5)));
            const int to = std::min(width - 1, static_cast<int>(std::floor(xs[k + 1] - 0.5)));
            for (int x = from; x <= to; ++x) set(x, y, rgb[0], rgb[1], rgb[2]);
        }
    }
}

RgbImage upscaled(const RgbImage& image, int factor) {
    PLUMAGE_CHECK(factor >= 1, fmt::format("upscale factor {}", factor));
    RgbImage out(image.width * factor, image.height * factor);
    for (int y = 0; y < out.height; ++y) {
        for (int x = 0; x < out.width; ++x) {
            const std::size_t i =
                (static_cast<std::size_t>(y / factor) * image.width + x / factor) * 3;
            out.set(x, y, image.pixels[i], image.pixels[i + 1], image.pixels[i + 2]);
        }
    }
    return out;
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

RgbImage side_by_side(const std::vector<const RgbImage*>& images) {
    int width = 0, height = 0;
    for (const auto* im : images) width += im->width + 6, height = std::max(height, im->height);
    RgbImage out(width - 6, height);
    out.fill(255, 255, 255);
    int x0 = 0;
    for (const auto* im : images) {
        for (int y = 0; y < im->height; ++y)
            for (int x = 0; x < im->width; ++x) {
                const std::size_t i = (static_cast<std::size_t>(y) * im->width + x) * 3;
                out.set(x0 + x, y, im->pixels[i], im->pixels[i + 1], im->pixels[i + 2]);
            }
        x0 += im->width + 6;
    }
    return out;
}

}  // namespace plumage::record
