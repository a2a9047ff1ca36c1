// 8-bit sRGB PNG output for scatterograms, charts and BRDF images.
#pragma once

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
};

// Written to a temporary name and renamed, like records; IoError on failure.
void write_png(const std::filesystem::path& path, const RgbImage& image);

}  // namespace plumage::record
