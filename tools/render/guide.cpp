#include "tools/render/guide.h"

#include <stdexcept>

#include "libcommon/spheremap.h"

namespace iris {

GuideMode parse_guide_mode(const std::string& s) {
    if (s == "nee+bsdf") return GuideMode::NeeBsdf;
    if (s == "nee+cache") return GuideMode::NeeCache;
    if (s == "bsdf+cache") return GuideMode::BsdfCache;
    if (s == "nee+bsdf+cache") return GuideMode::NeeBsdfCache;
    throw std::runtime_error("--mode must be nee+bsdf, nee+cache, bsdf+cache or nee+bsdf+cache, got \"" + s + "\"");
}

const char* guide_mode_name(GuideMode m) {
    switch (m) {
        case GuideMode::NeeBsdf: return "nee+bsdf";
        case GuideMode::NeeCache: return "nee+cache";
        case GuideMode::BsdfCache: return "bsdf+cache";
        case GuideMode::NeeBsdfCache: return "nee+bsdf+cache";
    }
    return "?";
}

namespace {
// A cache serves points up to this many times its gather radius away: the photons it holds came from
// that disc, so its directional distribution is representative there.
constexpr float kLookupSlack = 1.5f;
// Normal agreement between cache and vertex (cos 45 degrees).
constexpr float kLookupNormalCos = 0.7071f;
constexpr uint32_t kLookupCandidates = 4;
}  // namespace

Guide::Guide(CacheAtlas atlas, float bsdf_fraction) : atlas_(std::move(atlas)), alpha_(bsdf_fraction) {
    if (!(bsdf_fraction >= 0 && bsdf_fraction < 1)) throw std::runtime_error("--bsdf-fraction must be in [0, 1)");
    frames_.reserve(atlas_.size());
    for (size_t c = 0; c < atlas_.size(); ++c) {
        frames_.emplace_back(atlas_.normal[c]);
        if (!atlas_.usable[c]) continue;
        usable_positions_.push_back(atlas_.position[c]);
        usable_ids_.push_back(uint32_t(c));
        float r = atlas_.radius[c] * kLookupSlack;
        lookup_radius2_.push_back(r * r);
    }
    tree_ = std::make_unique<PointTree>(usable_positions_);
}

int Guide::lookup(Vec3 p, Vec3 n_side) const {
    if (usable_positions_.empty()) return -1;
    uint32_t idx[kLookupCandidates];
    float d2[kLookupCandidates];
    // Fast path: the nearest cache usually serves (a 1-nearest search costs a fraction of a 4-nearest
    // one); only at creases and thin walls, where it faces another way, look at a few more.
    uint32_t n = tree_->nearest(p, 1, kInf, idx, d2);
    for (int pass = 0; pass < 2; ++pass) {
        for (uint32_t i = 0; i < n; ++i) {
            if (d2[i] > lookup_radius2_[idx[i]]) continue;
            uint32_t c = usable_ids_[idx[i]];
            if (dot(atlas_.normal[c], n_side) < kLookupNormalCos) continue;
            prefetch(int(c));
            return int(c);
        }
        if (pass == 0) n = tree_->nearest(p, kLookupCandidates, kInf, idx, d2);
    }
    return -1;
}

void Guide::prefetch(int c) const {
    // The atlas is tens of MB and caches are visited in random order: start loading the CDF row now,
    // while the vertex's shadow ray is traced, so that sampling finds it in cache.
    const char* cdf = reinterpret_cast<const char*>(atlas_.cdf_row(size_t(c)));
    const char* pdf = reinterpret_cast<const char*>(atlas_.pdf_row(size_t(c)));
    const size_t bytes = atlas_.texels() * sizeof(float);
    for (size_t off = 0; off < bytes; off += 64) {
        __builtin_prefetch(cdf + off);
        __builtin_prefetch(pdf + off);
    }
}

Vec3 Guide::sample_local(int c, Vec2 u, float* pdf) const {
    return SphereDistribution::sample(atlas_.cdf_row(size_t(c)), atlas_.pdf_row(size_t(c)), atlas_.resolution, u, pdf);
}

float Guide::pdf(int c, Vec3 w) const {
    Vec3 local = frames_[size_t(c)].to_local(w);
    return SphereDistribution::pdf(atlas_.pdf_row(size_t(c)), atlas_.resolution, local);
}

}  // namespace iris
