#include "tools/inspect-caches/inspect.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "libcommon/bsdf.h"
#include "libcommon/camera.h"
#include "libcommon/spheremap.h"
#include "libguide/guide.h"

namespace iris {

namespace {

std::string fmt(const char* f, double a) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, a);
    return buf;
}

std::string line(const std::string& name, const std::string& value) {
    const size_t pad = name.size() < 24 ? 26 - name.size() : 2;  // values in one column
    return name + std::string(pad, ' ') + value + "\n";
}

// "min / median / p90 / max" of a sample (empty: "-").
std::string spread(std::vector<double> v, const char* f = "%.4g") {
    if (v.empty()) return "-";
    std::sort(v.begin(), v.end());
    auto at = [&](double q) { return v[size_t(q * double(v.size() - 1) + 0.5)]; };
    return fmt(f, v.front()) + " / " + fmt(f, at(0.5)) + " / " + fmt(f, at(0.9)) + " / " + fmt(f, v.back());
}

std::string vec(Vec3 v) { return fmt("%.4g", v.x) + ", " + fmt("%.4g", v.y) + ", " + fmt("%.4g", v.z); }

std::string bounds(const std::vector<Vec3>& p) {
    if (p.empty()) return "-";
    Vec3 lo(kInf), hi(-kInf);
    for (Vec3 q : p) lo = vmin(lo, q), hi = vmax(hi, q);
    std::string s = "(";  // (built by appending: GCC 12 warns falsely on the chained operator+ here)
    s += vec(lo);
    s += ") .. (";
    s += vec(hi);
    s += ")";
    return s;
}

std::string mib(double bytes) { return fmt("%.2f MiB", bytes / (1024.0 * 1024.0)); }

}  // namespace

std::string describe_header(const StageHeader& h) {
    std::string s = line("format", h.format + " v" + std::to_string(h.format_version));
    s += line("scene fingerprint", h.scene_fingerprint);
    s += line("made by", h.provenance.tool + " " + h.provenance.tool_version + ", " + h.created);
    s += line("command line", h.provenance.command_line);
    for (const auto& [name, value] : h.provenance.parameters) s += line("  " + name, fmt("%.6g", value));
    return s;
}

std::string describe_photon_map(const PhotonMap& m) {
    std::string s = line("photons", std::to_string(m.size()));
    s += line("emitted paths", std::to_string(m.emitted_paths));
    if (m.emitted_paths) s += line("photons per path", fmt("%.3f", double(m.size()) / double(m.emitted_paths)));
    s += line("max depth", m.max_depth < 0 ? "unlimited" : std::to_string(m.max_depth));
    RGB total(0.0f);
    std::vector<double> lum;
    lum.reserve(m.size());
    for (const RGB& p : m.power) {
        total += p;
        lum.push_back(luminance(p));
    }
    s += line("total power (W)", fmt("%.5g", total.r) + ", " + fmt("%.5g", total.g) + ", " + fmt("%.5g", total.b));
    s += line("photon power min/med/p90/max", spread(lum) + " W (luminance)");
    s += line("bounds", bounds(m.position));
    if (!m.bounces.empty()) {
        // Which light the caches will see: direct photons (0 bounces) are left to NEE by default.
        uint64_t hist[5] = {};
        for (uint8_t b : m.bounces) ++hist[std::min<int>(b, 4)];
        std::string h;
        for (int b = 0; b < 5; ++b)
            h += (b ? ", " : "") + std::to_string(b) + (b == 4 ? "+" : "") + ": " +
                 fmt("%.1f %%", 100.0 * double(hist[b]) / double(std::max<size_t>(1, m.size())));
        s += line("bounces before the hit", h);
    }
    // Light the path tracer can only find through specular chains (NEE cannot connect through them).
    if (const double share = caustic_power_share(m); share >= 0)
        s += line("caustic (via specular)", fmt("%.1f %% of the stored power", 100.0 * share));
    return s;
}

std::string describe_cache_points(const CachePoints& c) {
    size_t camera = size_t(std::count(c.origin.begin(), c.origin.end(), kCacheFromCamera));
    std::string s = line("caches", std::to_string(c.size()));
    s += line("placed from the camera", std::to_string(camera));
    s += line("placed at photons", std::to_string(c.size() - camera));
    s += line("bounds", bounds(c.position));
    return s;
}

std::string describe_cache_atlas(const CacheAtlas& a) {
    const size_t n = a.texels();
    std::string s = line("caches", std::to_string(a.size()));
    s += line("usable", std::to_string(std::count(a.usable.begin(), a.usable.end(), uint8_t(1))));
    s += line("map resolution", std::to_string(a.resolution) + " x " + std::to_string(a.resolution) + " (" +
                                    fmt("%.4g", 4 * kPi / double(std::max<size_t>(1, n))) + " sr per texel)");
    s += line("k, filter, sigma, floor",
              std::to_string(a.k) + ", " + a.filter + ", " + fmt("%.3g", a.filter_sigma) + ", " + fmt("%.3g", a.floor));
    s += line("memory of the maps", mib(double(a.pdf.size() + a.cdf.size()) * sizeof(float)) + " (pdf + cdf)");
    // What render holds: per cache a header and the packed map (libguide/guide.h).
    const size_t table = a.size() * Guide::bytes_per_cache(a.resolution);
    s += line("render's table", mib(double(table)) + " (" + std::to_string(table) + " bytes)");
    std::vector<double> photons, radius, peak, coverage;
    for (size_t i = 0; i < a.size(); ++i) {
        photons.push_back(a.photon_count[i]);
        radius.push_back(a.radius[i]);
        if (!a.usable[i] || n == 0) continue;
        // Peak: the largest density over the uniform one (1/(4 pi)). Coverage: exp(entropy) / N, the
        // share of the sphere the distribution effectively spreads over (1 = uniform).
        const float* pdf = a.pdf_row(i);
        const double texel = 4 * kPi / double(n);
        double mx = 0, h = 0;
        for (size_t k = 0; k < n; ++k) {
            mx = std::max(mx, double(pdf[k]));
            const double p = double(pdf[k]) * texel;
            if (p > 0) h -= p * std::log(p);
        }
        peak.push_back(mx * 4 * kPi);
        coverage.push_back(std::exp(h) / double(n));
    }
    s += line("photons min/med/p90/max", spread(photons, "%.0f"));
    s += line("radius min/med/p90/max", spread(radius));
    s += line("peak / uniform", spread(peak, "%.3g") + "   (usable caches)");
    s += line("coverage of the sphere", spread(coverage, "%.3f") + "   (exp(entropy)/texels; 1 = uniform)");
    if (!a.caustic_share.empty()) {
        std::vector<double> share(a.caustic_share.begin(), a.caustic_share.end());
        s += line("caustic share", spread(share, "%.3f") + "   (of each map's power, via specular bounces)");
    }
    return s;
}

std::string describe_cache(const CacheAtlas& a, size_t c) {
    if (c >= a.size()) throw std::runtime_error("cache " + std::to_string(c) + " does not exist (the atlas has " +
                                                std::to_string(a.size()) + ")");
    std::string s = line("cache", std::to_string(c));
    s += line("position", vec(a.position[c]));
    s += line("normal", vec(a.normal[c]));
    s += line("photons, radius", std::to_string(a.photon_count[c]) + ", " + fmt("%.4g", a.radius[c]));
    s += line("usable", a.usable[c] ? "yes" : "no");
    return s;
}

Image cache_pdf_image(const CacheAtlas& a, size_t c, PdfLayout layout, int size) {
    if (c >= a.size()) throw std::runtime_error("cache " + std::to_string(c) + " does not exist (the atlas has " +
                                                std::to_string(a.size()) + ")");
    if (size <= 0 || size > 4096) throw std::runtime_error("image size must be in 1..4096, got " + std::to_string(size));
    const int R = a.resolution;
    const float* pdf = a.pdf_row(c);
    Image img;
    if (layout == PdfLayout::LatLong) {
        img.height = size;
        img.width = 2 * size;
    } else {
        img.width = img.height = R * size;
    }
    std::vector<float> value(size_t(img.width) * size_t(img.height));
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            int texel;
            if (layout == PdfLayout::LatLong) {
                const double theta = kPi * (y + 0.5) / img.height, phi = 2 * kPi * (x + 0.5) / img.width;
                const Vec3 w(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                             float(std::cos(theta)));
                texel = sphere_texel_of(w, R);
            } else {
                texel = (y / size) * R + x / size;
            }
            value[size_t(y) * img.width + x] = pdf[texel];
        }
    for (const char* name : {"R", "G", "B", "Y"}) img.add_channel(name) = value;
    img.metadata["iris:tool"] = "inspect-caches";
    img.metadata["iris:cache"] = std::to_string(c);
    img.metadata["iris:layout"] = layout == PdfLayout::LatLong ? "latlong (theta down from the normal, phi across)"
                                                                : "equal-area octahedral texels";
    img.metadata["iris:units"] = "probability density per steradian";
    return img;
}

int cache_for_pixel(const Scene& scene, const CacheAtlas& a, int x, int y, int width, int height, std::string* why) {
    if (x < 0 || y < 0 || x >= width || y >= height)
        throw std::runtime_error("pixel " + std::to_string(x) + "," + std::to_string(y) + " is outside the " +
                                 std::to_string(width) + "x" + std::to_string(height) + " image");
    // Only the lookup is needed; the BSDF fraction is irrelevant here.
    Guide guide(a, 0.5f);
    Camera camera = scene.camera;
    camera_prepare(camera, width, height);
    // The pixel centre's primary ray, clipped like the renderer's.
    Ray ray = camera_ray(camera, x + 0.5f, y + 0.5f, width, height);
    for (int bounce = 0; bounce < 16; ++bounce) {
        SurfaceHit hit;
        BsdfScratch scratch;
        if (!scene.intersect(ray, &hit)) {
            *why = "the pixel's ray leaves the scene";
            return -1;
        }
        const Bsdf& bsdf = scene_bsdf_at(scene, hit, &scratch);
        const Vec3 wi = -ray.d;
        if (!bsdf_is_delta(bsdf)) {
            const Vec3 n_side = dot(hit.ng, wi) >= 0 ? hit.ng : -hit.ng;
            const int c = guide.lookup(hit.p, n_side);
            if (c < 0) *why = "no usable cache serves the point " + vec(hit.p);
            return c;
        }
        // Specular: follow refraction where there is one (uc near 1 picks it over reflection).
        BsdfSample s;
        if (!bsdf_sample(bsdf, hit.frame.to_local(wi), Vec2(0.5f, 0.5f), 0.999f, &s)) break;
        ray = spawn_ray(hit, hit.frame.to_world(s.wo));
    }
    *why = "the pixel's ray meets only specular surfaces";
    return -1;
}

}  // namespace iris
