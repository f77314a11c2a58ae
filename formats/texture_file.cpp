#include "formats/texture_file.h"

#include <cmath>

#include "formats/image_file.h"

namespace iris {

void set_bitmap_sampling(const BitmapOptions& o, Texture* t) {
    t->filter = o.filter;
    t->wrap_u = o.wrap_u;
    t->wrap_v = o.wrap_v;
    t->uscale = o.uscale;
    t->vscale = o.vscale;
    t->uoffset = o.uoffset;
    t->voffset = o.voffset;
}

Texture load_bitmap_texture(const std::string& path, const BitmapOptions& o) {
    if (!(o.gamma == 0.0f || o.gamma == -1.0f || (o.gamma > 0.0f && std::isfinite(o.gamma))))
        throw ImageError(path + ": gamma must be 0 (automatic), -1 (sRGB) or positive");
    ImageFile f = read_image_file(path);
    const Image& im = f.image;
    int src[3];
    bool decode = true;  // whether the gamma / sRGB curve applies
    if (o.channel.empty()) {
        src[0] = im.channel_index("R");
        src[1] = im.channel_index("G");
        src[2] = im.channel_index("B");
    } else {
        static const char* const kNames[] = {"r", "g", "b", "a"};
        static const char* const kChannels[] = {"R", "G", "B", "A"};
        int which = -1;
        for (int i = 0; i < 4; ++i)
            if (o.channel == kNames[i]) which = i;
        if (which < 0) throw ImageError(path + ": channel must be r, g, b or a, not \"" + o.channel + "\"");
        int c = im.channel_index(kChannels[which]);
        if (c < 0) throw ImageError(path + ": the image has no channel \"" + o.channel + "\"");
        src[0] = src[1] = src[2] = c;
        decode = which != 3;
    }
    // Which curve: Mitsuba decodes integer files with sRGB and leaves float files linear by default.
    enum { Linear, Srgb, Power } curve = Linear;
    if (decode) {
        if (o.gamma == -1.0f || (o.gamma == 0.0f && f.display_encoded)) curve = Srgb;
        else if (o.gamma > 0.0f && o.gamma != 1.0f) curve = Power;
    }

    Texture t;
    t.type = TextureType::Bitmap;
    t.width = im.width;
    t.height = im.height;
    set_bitmap_sampling(o, &t);
    const size_t n = size_t(im.width) * size_t(im.height);
    t.texels.resize(n);
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            float v = im.data[size_t(src[c])][i];
            if (curve == Srgb) v = srgb_to_linear(v);
            else if (curve == Power) v = gamma_to_linear(v, o.gamma);
            t.texels[i][c] = v;
        }
    return t;
}

}  // namespace iris
