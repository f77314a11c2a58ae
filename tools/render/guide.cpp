#include "tools/render/guide.h"

#include <sys/mman.h>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <stdexcept>

#include "libcommon/bsdf_fraction.h"
#include "libcommon/rng.h"
#include "libcommon/spheremap.h"
#include "libcommon/point_tree.h"

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
// Caches the tree fallback looks at (nearest first) where no cache of the vertex's cell serves it.
constexpr uint32_t kLookupCandidates = 8;
}  // namespace

// 2 MiB-aligned (the huge page size on x86-64) and advised for transparent huge pages.
std::unique_ptr<float[], Guide::FreeTable> Guide::allocate_table(size_t floats) {
    constexpr size_t kHuge = size_t(2) << 20;
    const size_t bytes = (floats * sizeof(float) + kHuge - 1) / kHuge * kHuge;
    void* p = std::aligned_alloc(kHuge, bytes);
    if (!p) throw std::bad_alloc();
    madvise(p, bytes, MADV_HUGEPAGE);  // advice only: without it the table is still correct
    return std::unique_ptr<float[], FreeTable>(static_cast<float*>(p));
}

void Guide::FreeTable::operator()(float* p) const { std::free(p); }

Guide::Guide(CacheAtlas atlas, const GuideOptions& o) : atlas_(std::move(atlas)) {
    const bool adaptive = o.bsdf_fraction < 0;
    if (!adaptive && !(o.bsdf_fraction < 1)) throw std::runtime_error("--bsdf-fraction must be in [0, 1)");
    if (!(o.min_gain >= 1) || !std::isfinite(o.min_gain)) throw std::runtime_error("--min-gain must be >= 1");
    const size_t n = atlas_.size();
    const int R = atlas_.resolution;
    frames_.reserve(n);
    alpha_.assign(n, 1.0f);
    const size_t N = atlas_.texels();
    cdf_offset_ = (size_t(R) + 15) / 16 * 16;
    stride_ = (cdf_offset_ + N + 15) / 16 * 16;
    per_sr_ = float(N) * kInv4Pi;
    table_ = allocate_table(std::max<size_t>(1, n * stride_));
    std::vector<uint32_t> guiding, claimants;
    summary_.caches = n;
    double sum_alpha = 0;
    // At least 0.2: the map is an estimate from a few hundred photons gathered over a disc, so BSDF
    // sampling keeps a share that bounds the weight where the map is wrong (defensive sampling).
    const BsdfFractionChooser chooser(std::max(R, 1), std::min(atlas_.floor, 0.999), 0.2f);
    for (size_t c = 0; c < n; ++c) {
        frames_.emplace_back(atlas_.normal[c]);
        float* block = table_.get() + c * stride_;
        const float* cdf = atlas_.cdf_row(c);
        std::copy(cdf, cdf + N, block + cdf_offset_);
        for (int j = 0; j < R; ++j) block[j] = cdf[size_t(j) * size_t(R) + size_t(R - 1)];
        // Every cache that gathered photons claims the vertices near it, guiding or not: where the
        // nearest cache is not worth guiding with, the light there is what it measured, and a farther
        // cache's map (from another place) is no better a guess. It also keeps the lookup short where
        // caches do not guide (no search for a distant one).
        if (atlas_.radius[c] > 0) claimants.push_back(uint32_t(c));
        if (!atlas_.usable[c]) continue;
        ++summary_.usable;
        float alpha = o.bsdf_fraction;
        if (adaptive) {
            const BsdfFractionChoice choice = chooser.choose(atlas_.pdf_row(c));
            if (choice.gain < o.min_gain) continue;
            alpha = choice.alpha;
        }
        alpha_[c] = alpha;
        sum_alpha += alpha;
        guiding.push_back(uint32_t(c));
    }
    // The maps now live in table_.
    atlas_.pdf = {};
    atlas_.cdf = {};
    summary_.guiding = guiding.size();
    summary_.mean_alpha = guiding.empty() ? 1.0 : sum_alpha / double(guiding.size());
    if (!guiding.empty()) build_grid(claimants);
}

void Guide::build_grid(const std::vector<uint32_t>& claimants) {
    positions_.clear();
    for (uint32_t c : claimants) positions_.push_back(atlas_.position[c]);
    claimant_ids_ = claimants;
    tree_ = std::make_unique<PointTree>(positions_);
    // Caches overlap heavily (serving radii are many spacings wide), so cells are sized by the spacing:
    // twice the median distance between neighbouring caches (over a sample), a handful of caches each.
    std::vector<float> spacing;
    const size_t n = positions_.size(), step = std::max<size_t>(1, n / 2000);
    for (size_t i = 0; i < n; i += step) {
        uint32_t idx[2];
        float d2[2];
        if (tree_->nearest(positions_[i], 2, kInf, idx, d2) == 2 && d2[1] > 0) spacing.push_back(std::sqrt(d2[1]));
    }
    float cell = 1.0f;
    if (!spacing.empty()) {
        std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
        cell = 2.0f * spacing[spacing.size() / 2];
    }
    if (!(cell > 0) || !std::isfinite(cell)) cell = 1.0f;
    inv_cell_ = 1.0f / cell;
    // Each cache is listed in every cell within half a cell of it, so a cell's list holds every cache
    // closer than half a cell to any of its points: the nearest cache is almost always among them.
    const float reach = 0.5f * cell;
    reach_ = reach;
    max_serve2_ = 0;
    for (uint32_t c : claimants) max_serve2_ = std::max(max_serve2_, sqr(atlas_.radius[c] * kLookupSlack));
    max_serve2_ = std::nextafter(max_serve2_, kInf);  // the tree's bound is exclusive
    grid_origin_ = Vec3(kInf);
    for (Vec3 p : positions_) grid_origin_ = vmin(grid_origin_, p - Vec3(reach));
    std::vector<std::pair<uint64_t, uint32_t>> listed;
    listed.reserve(4 * n);
    for (size_t i = 0; i < n; ++i) {
        const Vec3 lo = (positions_[i] - Vec3(reach) - grid_origin_) * inv_cell_;
        const Vec3 hi = (positions_[i] + Vec3(reach) - grid_origin_) * inv_cell_;
        for (int64_t z = int64_t(std::floor(lo.z)); z <= int64_t(std::floor(hi.z)); ++z)
            for (int64_t y = int64_t(std::floor(lo.y)); y <= int64_t(std::floor(hi.y)); ++y)
                for (int64_t x = int64_t(std::floor(lo.x)); x <= int64_t(std::floor(hi.x)); ++x)
                    listed.push_back({cell_key(x, y, z), uint32_t(i)});
    }
    std::sort(listed.begin(), listed.end());
    size_t cells = 0;
    for (size_t i = 0; i < listed.size(); ++i) cells += (i == 0 || listed[i].first != listed[i - 1].first);
    size_t cap = 16;
    while (cap < 2 * cells) cap *= 2;
    slots_.assign(cap, Slot{});
    entries_.clear();
    entries_.reserve(listed.size());
    for (size_t i = 0; i < listed.size();) {
        const uint64_t key = listed[i].first;
        Slot s;
        s.key = key;
        s.begin = uint32_t(entries_.size());
        for (; i < listed.size() && listed[i].first == key; ++i) {
            const uint32_t c = claimants[listed[i].second];
            const float r = atlas_.radius[c] * kLookupSlack;
            entries_.push_back({atlas_.position[c], r * r, atlas_.normal[c], c});
        }
        s.end = uint32_t(entries_.size());
        size_t slot = mix64(key) & (cap - 1);
        while (slots_[slot].key != ~0ull) slot = (slot + 1) & (cap - 1);
        slots_[slot] = s;
    }
}

uint64_t Guide::cell_key(int64_t x, int64_t y, int64_t z) const {
    // 21 bits per axis; cells more than 2^21 apart alias harmlessly (the scan re-tests the distance).
    return uint64_t(x & 0x1fffff) | (uint64_t(y & 0x1fffff) << 21) | (uint64_t(z & 0x1fffff) << 42);
}

int Guide::lookup(Vec3 p, Vec3 n_side) const {
    if (slots_.empty() || !is_finite(p)) return -1;
    // The grid lists in p's cell every cache within `reach` of p, so its answer is the nearest serving
    // cache whenever one is that close; a farther one it finds serves too, and is used as it is (any
    // fixed choice keeps the estimator unbiased; exact nearest-ness would cost a tree search at a
    // large share of vertices). Only when the cell has none does the tree decide.
    float d2 = kInf;
    int c = lookup_grid(p, n_side, &d2);
    if (c < 0) c = lookup_tree(p, n_side);
    if (c >= 0 && !(alpha_[size_t(c)] < 1)) return -1;  // claimed by a cache that does not guide
    if (c >= 0) {
        // Sampling reads the row ends first, then one row of the cdf: start loading the former now,
        // while the vertex's shadow ray is traced.
        const size_t R = size_t(atlas_.resolution);
        const char* rows = reinterpret_cast<const char*>(row_cdf(c));
        for (size_t off = 0; off < R * sizeof(float); off += 64) __builtin_prefetch(rows + off);
        __builtin_prefetch(&frames_[size_t(c)]);
    }
    return c;
}

int Guide::lookup_grid(Vec3 p, Vec3 n_side, float* best_d2) const {
    const Vec3 q = (p - grid_origin_) * inv_cell_;
    // Far outside the grid (or beyond int64): left to the tree.
    if (!(std::abs(q.x) < 1e15f && std::abs(q.y) < 1e15f && std::abs(q.z) < 1e15f)) return -1;
    const uint64_t key = cell_key(int64_t(std::floor(q.x)), int64_t(std::floor(q.y)), int64_t(std::floor(q.z)));
    const size_t mask = slots_.size() - 1;
    for (size_t slot = mix64(key) & mask;; slot = (slot + 1) & mask) {
        const Slot& s = slots_[slot];
        if (s.key == ~0ull) return -1;
        if (s.key != key) continue;
        int best = -1;
        for (uint32_t e = s.begin; e < s.end; ++e) {
            const GridEntry& g = entries_[e];
            const float d2 = length_sq(g.position - p);
            if (d2 < *best_d2 && d2 <= g.radius2 && dot(g.normal, n_side) >= kLookupNormalCos) {
                *best_d2 = d2;
                best = int(g.cache);
            }
        }
        return best;
    }
}

bool Guide::serves(uint32_t c, Vec3 n_side, float d2) const {
    const float r = atlas_.radius[c] * kLookupSlack;
    return d2 <= r * r && dot(atlas_.normal[c], n_side) >= kLookupNormalCos;
}

int Guide::lookup_tree(Vec3 p, Vec3 n_side) const {
    // The nearest few caches (sorted: the first that serves is the nearest serving one among them).
    // A vertex that none of them serves is left unguided rather than searched for a distant cache
    // with a wide disc: such vertices lie away from every cache (surfaces the camera does not see),
    // where a search of all caches within the widest serving distance would cost hundreds of
    // candidates for a map measured elsewhere.
    uint32_t idx[kLookupCandidates];
    float d2[kLookupCandidates];
    const uint32_t n = tree_->nearest(p, kLookupCandidates, max_serve2_, idx, d2);
    for (uint32_t i = 0; i < n; ++i)
        if (serves(claimant_ids_[idx[i]], n_side, d2[i])) return int(claimant_ids_[idx[i]]);
    return -1;
}

Vec3 Guide::sample(int c, Vec2 u, float* pdf) const {
    int k;
    const Vec3 local = SphereDistribution::sample_by_rows(cdf_row(c), row_cdf(c), atlas_.resolution, u, &k);
    if (pdf) *pdf = texel_pdf(c, k);
    return frames_[size_t(c)].to_world(local);
}

void Guide::prefetch_sample(int c, Vec2 u) const {
    const int R = atlas_.resolution;
    const int j = SphereDistribution::search_cdf(row_cdf(c), R, std::min(std::max(u.x, 0.0f), 0x1.fffffep-1f));
    const char* row = reinterpret_cast<const char*>(cdf_row(c) + size_t(j) * size_t(R));
    for (size_t off = 0; off < size_t(R) * sizeof(float); off += 64) __builtin_prefetch(row + off);
}

}  // namespace iris
