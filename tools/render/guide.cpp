#include "tools/render/guide.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "libcommon/rng.h"

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
    build_grid();
}

void Guide::build_grid() {
    const size_t n = usable_positions_.size();
    if (n < 2) return;
    // Cell size: twice the typical spacing between neighbouring caches (median over a sample of
    // nearest-neighbour distances), so a cell on a surface holds a handful of caches.
    std::vector<float> spacing;
    const size_t step = std::max<size_t>(1, n / 2000);
    for (size_t i = 0; i < n; i += step) {
        uint32_t idx[2];
        float d2[2];
        if (tree_->nearest(usable_positions_[i], 2, kInf, idx, d2) == 2 && d2[1] > 0) spacing.push_back(std::sqrt(d2[1]));
    }
    if (spacing.empty()) return;
    std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
    cell_size_ = 2.0f * spacing[spacing.size() / 2];
    if (!(cell_size_ > 0) || !std::isfinite(cell_size_)) return;
    inv_cell_ = 1.0f / cell_size_;
    grid_origin_ = Vec3(kInf);
    for (Vec3 p : usable_positions_) grid_origin_ = vmin(grid_origin_, p);
    std::vector<std::pair<uint64_t, uint32_t>> keyed(n);
    for (size_t i = 0; i < n; ++i) keyed[i] = {cell_key(usable_positions_[i]), uint32_t(i)};
    std::sort(keyed.begin(), keyed.end());
    size_t cells = 0;
    for (size_t i = 0; i < n; ++i) cells += (i == 0 || keyed[i].first != keyed[i - 1].first);
    size_t cap = 16;
    while (cap < 2 * cells) cap *= 2;
    slot_key_.assign(cap, ~0ull);
    slot_begin_.assign(cap, 0);
    slot_end_.assign(cap, 0);
    entries_.reserve(n);
    for (size_t i = 0; i < n;) {
        size_t j = i;
        uint64_t key = keyed[i].first;
        uint32_t begin = uint32_t(entries_.size());
        for (; j < n && keyed[j].first == key; ++j) {
            uint32_t u = keyed[j].second, c = usable_ids_[u];
            entries_.push_back({usable_positions_[u], atlas_.normal[c], lookup_radius2_[u], c});
        }
        size_t slot = mix64(key) & (cap - 1);
        while (slot_key_[slot] != ~0ull) slot = (slot + 1) & (cap - 1);
        slot_key_[slot] = key;
        slot_begin_[slot] = begin;
        slot_end_[slot] = uint32_t(entries_.size());
        i = j;
    }
}

uint64_t Guide::cell_key(Vec3 p) const {
    // 21 bits per axis; cells far outside the caches' extent alias harmlessly (the scan re-tests).
    Vec3 q = (p - grid_origin_) * inv_cell_;
    auto axis = [](float v) { return uint64_t(int64_t(std::floor(v)) & 0x1fffff); };
    return axis(q.x) | (axis(q.y) << 21) | (axis(q.z) << 42);
}

int Guide::lookup(Vec3 p, Vec3 n_side) const {
    if (usable_positions_.empty()) return -1;
    int c = lookup_grid(p, n_side);
    if (c < 0) c = lookup_tree(p, n_side);
    if (c >= 0) prefetch(c);
    return c;
}

int Guide::lookup_grid(Vec3 p, Vec3 n_side) const {
    if (slot_key_.empty() || !is_finite(p)) return -1;
    const uint64_t key = cell_key(p);
    const size_t mask = slot_key_.size() - 1;
    for (size_t slot = mix64(key) & mask;; slot = (slot + 1) & mask) {
        uint64_t k = slot_key_[slot];
        if (k == ~0ull) return -1;
        if (k != key) continue;
        // The nearest cache inside the cell that may serve this vertex.
        int best = -1;
        float best_d2 = kInf;
        for (uint32_t e = slot_begin_[slot]; e < slot_end_[slot]; ++e) {
            const GridEntry& g = entries_[e];
            float d2 = length_sq(g.position - p);
            if (d2 < best_d2 && d2 <= g.radius2 && dot(g.normal, n_side) >= kLookupNormalCos) {
                best_d2 = d2;
                best = int(g.cache);
            }
        }
        return best;
    }
}

int Guide::lookup_tree(Vec3 p, Vec3 n_side) const {
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
