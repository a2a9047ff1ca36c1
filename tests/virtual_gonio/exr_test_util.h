// Reading EXR files in tests with OpenEXR's own API (Imf::MultiPartInputFile), so the tests do
// not trust our writer to check itself.
#pragma once

#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>

namespace plumage::testing {

// The channel names of a part, in OpenEXR's (alphabetical) order.
inline std::vector<std::string> exr_channel_names(const Imf::Header& header) {
    std::vector<std::string> names;
    for (auto c = header.channels().begin(); c != header.channels().end(); ++c)
        names.emplace_back(c.name());
    return names;
}

// One float channel of one part, row-major from the top row.
inline std::vector<float> exr_channel(Imf::MultiPartInputFile& file, int part_index,
                                      const std::string& name) {
    Imf::InputPart part(file, part_index);
    const auto window = part.header().dataWindow();
    const int width = window.max.x - window.min.x + 1;
    const int height = window.max.y - window.min.y + 1;
    std::vector<float> data(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
    Imf::FrameBuffer frame;
    // The slice's base points at pixel (0, 0) of the data window's coordinates.
    char* base =
        reinterpret_cast<char*>(data.data()) - (static_cast<std::ptrdiff_t>(window.min.x) +
                                                static_cast<std::ptrdiff_t>(window.min.y) * width) *
                                                   static_cast<std::ptrdiff_t>(sizeof(float));
    frame.insert(name, Imf::Slice(Imf::FLOAT, base, sizeof(float),
                                  sizeof(float) * static_cast<std::size_t>(width)));
    part.setFrameBuffer(frame);
    part.readPixels(window.min.y, window.max.y);
    return data;
}

}  // namespace plumage::testing
