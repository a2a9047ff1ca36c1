// 8-bit sRGB PNG output for scatterograms, charts and BRDF images.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace plumage::record {

// Row-major RGB8 image, row 0 at the top.
struct RgbImage {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> pixels;  // width * height * 3

    RgbImage(int w, int h);
    void set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b);
    void fill(std::uint8_t r, std::uint8_t g, std::uint8_t b);
    // Drawing for previews, in pixel coordinates (x right, y down); clipped to the image.
    void draw_line(double x0, double y0, double x1, double y1,
                   const std::array<std::uint8_t, 3>& rgb);
    // Even–odd scanline fill of a closed polygon given as (x, y) pairs.
    void fill_polygon(const std::vector<std::array<double, 2>>& polygon,
                      const std::array<std::uint8_t, 3>& rgb);
};

// Nearest-neighbour enlargement by an integer factor, so small instrument images are
// readable without resampling their values.
RgbImage upscaled(const RgbImage& image, int factor);

// Written to a temporary name and renamed, like records; IoError on failure.
void write_png(const std::filesystem::path& path, const RgbImage& image);

// Images left to right on white, 6 px apart, top-aligned.
RgbImage side_by_side(const std::vector<const RgbImage*>& images);

}  // namespace plumage::record
