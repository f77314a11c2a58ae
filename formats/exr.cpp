// STUB: to be replaced by the real implementation.
#include "formats/exr.h"
namespace iris {
int Image::channel_index(const std::string& name) const {
    for (size_t i = 0; i < channels.size(); ++i)
        if (channels[i] == name) return int(i);
    return -1;
}
std::vector<float>& Image::add_channel(const std::string& name) {
    channels.push_back(name);
    data.emplace_back(size_t(width) * size_t(height), 0.0f);
    return data.back();
}
void write_exr(const std::string& path, const Image&) { throw ImageError(path + ": not implemented"); }
Image read_exr(const std::string& path) { throw ImageError(path + ": not implemented"); }
Image read_png(const std::string& path) { throw ImageError(path + ": not implemented"); }
}  // namespace iris
