#include "formats/film_parts.h"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace iris {

namespace {

constexpr int kPieceBits = 22;  // 3 x 22 >= 64; an integer below 2^22 is exact in a float
constexpr uint64_t kPieceMask = (uint64_t(1) << kPieceBits) - 1;
const char* const kRGB[3] = {"R", "G", "B"};

// Channels of one double per pixel: NAME.b0, NAME.b1, NAME.b2.
void add_doubles(Image& img, const std::string& name, const std::vector<double>& v, size_t stride, size_t offset) {
    const size_t n = size_t(img.width) * img.height;
    for (int k = 0; k < 3; ++k) {
        std::vector<float>& ch = img.add_channel(name + ".b" + std::to_string(k));
        for (size_t i = 0; i < n; ++i) {
            uint64_t bits;
            std::memcpy(&bits, &v[stride * i + offset], sizeof bits);
            ch[i] = float((bits >> (kPieceBits * k)) & kPieceMask);
        }
    }
}

void read_doubles(const Image& img, const std::string& path, const std::string& name, std::vector<double>& v,
                  size_t stride, size_t offset) {
    const size_t n = size_t(img.width) * img.height;
    int idx[3];
    for (int k = 0; k < 3; ++k) {
        idx[k] = img.channel_index(name + ".b" + std::to_string(k));
        if (idx[k] < 0) throw ImageError(path + ": partial render without channel '" + name + ".b" + std::to_string(k) + "'");
    }
    for (size_t i = 0; i < n; ++i) {
        uint64_t bits = 0;
        for (int k = 0; k < 3; ++k) {
            const float f = img.data[size_t(idx[k])][i];
            if (!(f >= 0 && f <= float(kPieceMask) && f == std::floor(f)))
                throw ImageError(path + ": channel '" + name + ".b" + std::to_string(k) + "' is damaged (pixel " +
                                 std::to_string(i) + " is not a 22-bit integer)");
            bits |= uint64_t(f) << (kPieceBits * k);
        }
        double d;
        std::memcpy(&d, &bits, sizeof d);
        if (!std::isfinite(d)) throw ImageError(path + ": channel '" + name + "' holds a non-finite sum at pixel " + std::to_string(i));
        v[stride * i + offset] += d;
    }
}

}  // namespace

void add_film_layers(Image& img, const Film& film, bool variance, bool samples) {
    img.width = film.width;
    img.height = film.height;
    // (add_channel may reallocate the channel list: index the data after adding.)
    int first = int(img.channels.size());
    for (const char* name : {"R", "G", "B"}) img.add_channel(name);
    for (int y = 0; y < film.height; ++y)
        for (int x = 0; x < film.width; ++x) {
            RGB v = film.value(x, y);
            size_t i = size_t(y) * film.width + x;
            for (int c = 0; c < 3; ++c) img.data[size_t(first + c)][i] = v[c];
        }
    if (variance) {
        first = int(img.channels.size());
        for (const char* name : {"variance.R", "variance.G", "variance.B"}) img.add_channel(name);
        for (int y = 0; y < film.height; ++y)
            for (int x = 0; x < film.width; ++x) {
                RGB v = film.variance(x, y);
                size_t i = size_t(y) * film.width + x;
                for (int c = 0; c < 3; ++c) img.data[size_t(first + c)][i] = v[c];
            }
    }
    if (samples) {
        auto& S = img.add_channel("samples");
        for (size_t i = 0; i < S.size(); ++i) S[i] = float(film.count[i]);
    }
}

void add_film_parts(Image& img, const Film& film) {
    for (int c = 0; c < 3; ++c) {
        add_doubles(img, std::string("part.sum_wl.") + kRGB[c], film.sum_wl, 3, size_t(c));
        add_doubles(img, std::string("part.sum_wl2.") + kRGB[c], film.sum_wl2, 3, size_t(c));
    }
    add_doubles(img, "part.sum_w", film.sum_w, 1, 0);
    std::vector<float>& count = img.add_channel("part.count");
    for (size_t i = 0; i < count.size(); ++i) count[i] = float(film.count[i]);
    if (film.light_paths_per_sample > 0)
        for (int c = 0; c < 3; ++c) {
            add_doubles(img, std::string("part.light_sum.") + kRGB[c], film.light_sum, 3, size_t(c));
            add_doubles(img, std::string("part.light_sum2.") + kRGB[c], film.light_sum2, 3, size_t(c));
        }
}

bool has_film_parts(const Image& img) { return img.channel_index("part.count") >= 0; }

void accumulate_film_parts(const Image& img, const std::string& path, Film& film) {
    if (img.width != film.width || img.height != film.height)
        throw ImageError(path + ": resolution " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                         " differs from the other parts' " + std::to_string(film.width) + "x" + std::to_string(film.height));
    for (int c = 0; c < 3; ++c) {
        read_doubles(img, path, std::string("part.sum_wl.") + kRGB[c], film.sum_wl, 3, size_t(c));
        read_doubles(img, path, std::string("part.sum_wl2.") + kRGB[c], film.sum_wl2, 3, size_t(c));
    }
    read_doubles(img, path, "part.sum_w", film.sum_w, 1, 0);
    const int ci = img.channel_index("part.count");
    if (ci < 0) throw ImageError(path + ": not a partial render (no channel 'part.count'; render --sample-range writes it)");
    for (size_t i = 0; i < film.count.size(); ++i) {
        const float f = img.data[size_t(ci)][i];
        if (!(f >= 0 && f < float(kMaxPartSpp) && f == std::floor(f)))
            throw ImageError(path + ": channel 'part.count' is damaged at pixel " + std::to_string(i));
        film.count[i] += uint32_t(f);
    }
    if (film.light_paths_per_sample > 0)
        for (int c = 0; c < 3; ++c) {
            read_doubles(img, path, std::string("part.light_sum.") + kRGB[c], film.light_sum, 3, size_t(c));
            read_doubles(img, path, std::string("part.light_sum2.") + kRGB[c], film.light_sum2, 3, size_t(c));
        }
}

void strip_film_parts(Image& img) {
    for (size_t i = img.channels.size(); i-- > 0;)
        if (img.channels[i].rfind("part.", 0) == 0) {
            img.channels.erase(img.channels.begin() + long(i));
            img.data.erase(img.data.begin() + long(i));
        }
}

}  // namespace iris
