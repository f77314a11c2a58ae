// OpenEXR images: linear float RGB with optional extra layers and string metadata.
// Written atomically: to "<path>.tmp-<pid>" first, then renamed, so a killed writer never leaves a
// truncated file under the final name.
#pragma once

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace iris {

struct ImageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// A multi-channel float image. Channels are named like OpenEXR channels: "R","G","B" for the beauty,
// "variance.R" etc. for layers. Pixel (x, y) of channel c is data[c][y * width + x].
struct Image {
    int width = 0, height = 0;
    std::vector<std::string> channels;
    std::vector<std::vector<float>> data;
    std::map<std::string, std::string> metadata;

    int channel_index(const std::string& name) const;  // -1 if absent
    std::vector<float>& add_channel(const std::string& name);
};

// Writes all channels as 32-bit float, ZIP-compressed. Throws ImageError naming the path.
void write_exr(const std::string& path, const Image& image);
// Reads every channel as float, and the string attributes into metadata. Throws ImageError.
Image read_exr(const std::string& path);
// Reads an 8-bit PNG (sRGB-encoded) into R,G,B channels with values 0..1 as stored (not linearised).
Image read_png(const std::string& path);

}  // namespace iris
