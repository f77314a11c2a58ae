#include "libguide/guide.h"
#include "libcommon/mutation.h"

#include <sys/mman.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <cmath>
#include <stdexcept>

#include "libguide/bsdf_fraction.h"
#include "libcommon/rng.h"
#include "libguide/packed_map.h"
#include "libcommon/point_tree.h"
#include "libcommon/spheremap.h"

namespace iris {

GuideMode parse_guide_mode(const std::string& s) {
    if (s == "nee+bsdf") return GuideMode::NeeBsdf;
    if (s == "nee+cache") return GuideMode::NeeCache;
    if (s == "bsdf+cache") return GuideMode::BsdfCache;
    if (s == "nee+bsdf+cache") return GuideMode::NeeBsdfCache;
    throw std::runtime_error("mode must be nee+bsdf, nee+cache, bsdf+cache or nee+bsdf+cache, got \"" + s + "\"");
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

static_assert(kCacheAtlasMaxResolution <= packed_map::kMaxResolution,
              "every map an atlas may hold must pack (formats/cache_atlas.h, libguide/packed_map.h)");

namespace {
// A cache serves points up to this many times its gather radius away: the photons it holds came from
// that disc, so its directional distribution is representative there.
constexpr float kLookupSlack = 1.5f;
// Normal agreement between cache and vertex (cos 45 degrees).
constexpr float kLookupNormalCos = 0.7071f;
}  // namespace

HugeMemory allocate_huge(size_t bytes) {
    constexpr size_t kHuge = size_t(2) << 20;
    const size_t size = (bytes + kHuge - 1) / kHuge * kHuge;
    void* p = std::aligned_alloc(kHuge, size);
    if (!p) throw std::bad_alloc();
    madvise(p, size, MADV_HUGEPAGE);  // advice only: without it the memory is still correct
    return HugeMemory(static_cast<unsigned char*>(p));
}

void FreeHuge::operator()(void* p) const { std::free(p); }

Guide::Guide(CacheAtlas atlas, const GuideOptions& o) : atlas_(std::move(atlas)), options_(o) {
    if (!(o.bsdf_fraction < 0) && !(o.bsdf_fraction < 1)) throw std::runtime_error("bsdf-fraction must be in [0, 1)");
    if (!(o.min_gain >= 1) || !std::isfinite(o.min_gain)) throw std::runtime_error("min-gain must be >= 1");
    const size_t n = atlas_.size();
    const int R = atlas_.resolution;
    const size_t N = atlas_.texels();
    stride_ = bytes_per_cache(R);
    per_sr_ = float(N) * kInv4Pi;
    table_ = allocate_huge(std::max<size_t>(1, n * stride_));
    summary_.table_bytes = n * stride_;
    summary_.caches = n;
    // At least 0.2: the map is an estimate from a few hundred photons gathered over a disc, so BSDF
    // sampling keeps a share that bounds the weight where the map is wrong (defensive sampling).
    const BsdfFractionChooser chooser(std::max(R, 1), std::min(atlas_.floor, 0.999), 0.2f);
    // Each cache's block, in parallel (packing and choosing alpha are most of the guide's set-up time):
    // its frame, its packed map and its BSDF share, 1 where it does not guide (unusable, or predicted
    // to gain less than min_gain).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t c = range.begin(); c != range.end(); ++c) {
            unsigned char* dst = table_.get() + c * stride_;
            const Frame f(atlas_.normal[c]);
            const float alpha = atlas_.usable[c] ? choose_alpha(chooser, atlas_.pdf_row(c)) : 1.0f;
            const float h[kHeader] = {f.s.x, f.s.y, f.s.z, f.t.x, f.t.y, f.t.z, f.n.x, f.n.y, f.n.z, alpha,
                                      o.learn ? 1.0f : 0.0f};
            std::copy(h, h + kHeader, reinterpret_cast<float*>(dst));
            packed_map::encode(atlas_.pdf_row(c), R, dst + kHeader * sizeof(float));
        }
    });
    if (o.product && R >= kProductBlocks && R % kProductBlocks == 0) {
        constexpr int B = kProductBlocks;
        for (int bj = 0; bj < B; ++bj)
            for (int bi = 0; bi < B; ++bi) {
                const Vec3 d = square_to_sphere({(float(bi) + 0.5f) / B, (float(bj) + 0.5f) / B});
                block_x_[bj * B + bi] = d.x;
                block_y_[bj * B + bi] = d.y;
                block_z_[bj * B + bi] = d.z;
            }
        block_mass_.assign(n * B * B, 0.0f);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t c = range.begin(); c != range.end(); ++c) fill_block_mass(c);
        });
    }
    if (o.learn) {
        // The photon maps without their floor, for refit(): texel probability pdf * 4 pi / N, less the
        // floor's f / N, over 1 - f (the inverse of SphereMap::normalise_floor).
        const double f = atlas_.floor, omega = 4.0 * M_PI / double(N);
        photon_pmf_.assign(n * N, 0.0f);
        current_pmf_.assign(n * N, 0.0f);
        path_used_.assign(n, 0);
        path_effective_.assign(n, 0.0f);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t c = range.begin(); c != range.end(); ++c) {
                const float* pdf = atlas_.pdf_row(c);
                double total = 0;
                for (size_t k = 0; k < N; ++k) {
                    current_pmf_[c * N + k] = float(double(pdf[k]) * omega);
                    if (atlas_.usable[c] && f < 1) {
                        const double p = std::max(0.0, (double(pdf[k]) * omega - f / double(N)) / (1 - f));
                        photon_pmf_[c * N + k] = float(p);
                        total += p;
                    }
                }
                if (total > 0)
                    for (size_t k = 0; k < N; ++k) photon_pmf_[c * N + k] = float(photon_pmf_[c * N + k] / total);
            }
        });
    }
    std::vector<uint32_t> claimants;
    for (size_t c = 0; c < n; ++c) {
        // Every cache that gathered photons claims the vertices near it, guiding or not: where the
        // nearest cache is not worth guiding with, the light there is what it measured, and a farther
        // cache's map (from another place) is no better a guess. It also keeps the lookup short where
        // caches do not guide (no search for a distant one).
        if (atlas_.radius[c] > 0) claimants.push_back(uint32_t(c));
        summary_.usable += atlas_.usable[c] ? 1 : 0;
    }
    // The maps now live in table_.
    atlas_.pdf = {};
    atlas_.cdf = {};
    summarise_guiding();
    if (summary_.guiding > 0 || o.learn) build_grid(claimants);
}

float Guide::choose_alpha(const BsdfFractionChooser& chooser, const float* pdf) const {
    if (!(options_.bsdf_fraction < 0)) return options_.bsdf_fraction;
    const BsdfFractionChoice choice = chooser.choose(pdf);
    return choice.gain >= options_.min_gain ? choice.alpha : 1.0f;
}

void Guide::summarise_guiding() {
    size_t guiding = 0;
    double sum_alpha = 0;
    for (size_t c = 0; c < atlas_.size(); ++c)
        if (bsdf_fraction(int(c)) < 1) {
            ++guiding;
            sum_alpha += bsdf_fraction(int(c));
        }
    summary_.guiding = guiding;
    summary_.mean_alpha = guiding == 0 ? 1.0 : sum_alpha / double(guiding);
}

void Guide::build_grid(const std::vector<uint32_t>& claimants) {
    std::vector<Vec3> positions;
    for (uint32_t c : claimants) positions.push_back(atlas_.position[c]);
    const PointTree tree(positions);
    max_serve2_ = 0;
    for (uint32_t c : claimants) max_serve2_ = std::max(max_serve2_, sqr(atlas_.radius[c] * kLookupSlack));
    max_serve2_ = std::nextafter(max_serve2_, kInf);  // the tree's bound is exclusive
    // Fine cells two cache spacings wide (the median distance between neighbouring caches, over a
    // sample): a vertex is then at most ~1.7 spacings from the centre its answer was chosen for, while
    // the caches serve several spacings around them. (One spacing, with the grid reaching two cells
    // around each cache, gave the same noise per sample on the glass spheres, 3x the cells and a
    // slower render.)
    std::vector<float> spacing;
    const size_t n = positions.size(), step = std::max<size_t>(1, n / 2000);
    for (size_t i = 0; i < n; i += step) {
        uint32_t idx[2];
        float d2[2];
        if (tree.nearest(positions[i], 2, kInf, idx, d2) == 2 && d2[1] > 0) spacing.push_back(std::sqrt(d2[1]));
    }
    float cell = 1.0f;
    if (!spacing.empty()) {
        std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
        cell = 2.0f * spacing[spacing.size() / 2];
    }
    if (!(cell > 0) || !std::isfinite(cell)) cell = 1.0f;
    // The fine grid covers every cell within half a cell of a cache (2x2x2 cells per cache): the
    // surfaces around the caches, where most vertices that caches serve lie. (Within one cell: 16 MB
    // of slots on the egg where both grids now take 1.2 MB, the same noise per sample and 2 % more time
    // per sample on the egg and the spheres.) The coarse grid covers each cache's whole serving distance, with cells four
    // fine cells wide (on the egg the same noise per sample as two, a quarter of the cells to fill).
    fill_grid(fine_, cell, std::vector<float>(n, 0.5f * cell), claimants, tree);
    std::vector<float> serve(n);
    for (size_t i = 0; i < n; ++i) serve[i] = atlas_.radius[claimants[i]] * kLookupSlack;
    fill_grid(coarse_, std::max(4 * fine_.cell, 0.5f * std::sqrt(max_serve2_)), serve, claimants, tree);
    summary_.grid_bytes = (fine_.slots.size() + coarse_.slots.size()) * sizeof(Slot);
}

void Guide::fill_grid(Grid& g, float cell, const std::vector<float>& reach, const std::vector<uint32_t>& claimants,
                      const PointTree& tree) const {
    const size_t n = claimants.size();
    Vec3 lo_all(kInf), hi_all(-kInf);
    for (size_t i = 0; i < n; ++i) {
        const Vec3 p = atlas_.position[claimants[i]];
        lo_all = vmin(lo_all, p - Vec3(reach[i])), hi_all = vmax(hi_all, p + Vec3(reach[i]));
    }
    g.origin = lo_all;
    // Grow the cells until the grid fits 2^21 cells per axis (only for scenes whose caches span more
    // than two million spacings).
    g.cell = std::max(cell, max_component(hi_all - lo_all) / float(1 << 20));
    g.inv_cell = 1.0f / g.cell;
    std::vector<uint64_t> keys;
    keys.reserve(8 * n);
    for (size_t i = 0; i < n; ++i) {
        const Vec3 p = atlas_.position[claimants[i]];
        int64_t x0, y0, z0, x1, y1, z1;
        if (!g.cell_of(p - Vec3(reach[i]), &x0, &y0, &z0) || !g.cell_of(p + Vec3(reach[i]), &x1, &y1, &z1)) continue;
        for (int64_t z = z0; z <= z1; ++z)
            for (int64_t y = y0; y <= y1; ++y)
                for (int64_t x = x0; x <= x1; ++x) keys.push_back(Grid::key(x, y, z));
    }
    tbb::parallel_sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    size_t cap = 16;
    while (cap < 2 * keys.size()) cap *= 2;
    g.slots.assign(cap, Slot{});
    // No cache farther than this from a cell's centre serves a point of the cell (half its diagonal).
    const float cell_serve2 = sqr(std::sqrt(max_serve2_) + 0.8661f * g.cell);
    const Vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    // The cells' answers in parallel (a k-nearest search each), then their insertion in key order.
    std::vector<Slot> cells(keys.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, keys.size(), 256), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            const uint64_t key = keys[i];
            Slot& s = cells[i];
            s.key = key;
            const Vec3 center = g.center(int64_t(key & 0x1fffff), int64_t((key >> 21) & 0x1fffff), int64_t(key >> 42));
            uint32_t idx[kAnswerCandidates];
            float d2[kAnswerCandidates];
            const uint32_t found = tree.nearest(center, kAnswerCandidates, cell_serve2, idx, d2);
            const Vec3 half(0.5f * g.cell);
            for (int a = 0; a < 6; ++a) {
                const int c = first_serving(claimants, idx, found, center - half, center + half, axes[a]);
                // (Learning: every claimant answers; one that does not guide yet has BSDF share 1, so
                // its vertices sample the BSDF alone and only record what they receive.)
                s.answer[a] = c >= 0 && (options_.learn || bsdf_fraction(c) < 1) ? c : -1;
            }
        }
    });
    for (const Slot& s : cells) {
        size_t slot = mix64(s.key) & (cap - 1);
        while (g.slots[slot].key != ~0ull) slot = (slot + 1) & (cap - 1);
        g.slots[slot] = s;
    }
}

const Guide::Slot* Guide::Grid::find(const CellRef& r) const {
    if (r.key == ~0ull) return nullptr;
    const size_t mask = slots.size() - 1;
    for (size_t slot = r.slot;; slot = (slot + 1) & mask) {
        const Slot& s = slots[slot];
        if (s.key == r.key) return &s;
        if (s.key == ~0ull) return nullptr;
    }
}

bool Guide::cell_center(Vec3 p, Vec3* center, float* width) const {
    for (const Grid* g : {&fine_, &coarse_}) {
        int64_t x, y, z;
        if (g->find(p) && g->cell_of(p, &x, &y, &z)) {
            *width = g->cell;
            *center = g->center(x, y, z);
            return true;
        }
    }
    return false;
}

int Guide::lookup(const Probe& q, Vec3 n_side) const {
    const Slot* s = fine_.find(q.fine);
    if (!s) s = coarse_.find(q.coarse);
    if (!s) return -1;  // no cache serves p
    const int c = s->answer[normal_class(n_side)];
    if (c >= 0) {
        // Every guided vertex reads the header (frame, alpha) and the row ends: start loading them now.
        // (Two lines up to R = 32, then one more per 32 rows: the two unconditionally, as a loop over
        // them cost a mispredicted exit at about every lookup.)
        const unsigned char* head = block(c);
        prefetch(head);
        prefetch(head + 64);
        for (size_t off = 128; off < kHeader * sizeof(float) + packed_map::row_end_bytes(atlas_.resolution); off += 64)
            prefetch(head + off);
    }
    return c;
}

int Guide::first_serving(const std::vector<uint32_t>& claimants, const uint32_t* idx, uint32_t n, Vec3 lo, Vec3 hi,
                         Vec3 normal) const {
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t c = claimants[idx[i]];
        const float r = atlas_.radius[c] * kLookupSlack;
        const Vec3 q = atlas_.position[c];
        const Vec3 out = vmax(vmax(lo - q, q - hi), Vec3(0.0f));  // q's distance from the box, per axis
        if (length_sq(out) <= r * r && dot(atlas_.normal[c], normal) >= kLookupNormalCos) return int(c);
    }
    return -1;
}

namespace {
// Row j's probability over the run of b texels from column i0 of a packed map, in units of
// 1 / kRowTotal^2 (the row's count times the run's texel counts, packed_map.h: exact integers), and in
// *start the row's cumulative texel count before the run. A block's mass and the choice of a row inside
// it both read this.
uint64_t run_weight(const unsigned char* map, int R, int j, int i0, int b, uint32_t* start) {
    const uint16_t* te = packed_map::texel_end(map, R, j);
    uint32_t lo;
    *start = i0 > 0 ? te[i0 - 1] : 0u;
    return uint64_t(packed_map::interval(packed_map::row_end(map), j, &lo)) * (uint32_t(te[i0 + b - 1]) - *start);
}

// The product's lobe weight exp(k (cos - 1)) for 4 blocks at once, k >= 0: a positive stand-in for the
// exponential, 2^(x log2 e) from the exponent bits and a cubic for the fraction (within 0.1 % of exp).
// The weight needs only be positive and the same wherever it is read (the density divides by the same
// values), not exact; computed for 64 blocks at every glossy guided vertex, libm's exp took 15 % of a
// render's time.
#if defined(__SSE2__)
inline __m128 lobe_weight(__m128 cos, __m128 k) {
    const __m128 x = _mm_mul_ps(k, _mm_sub_ps(_mm_min_ps(cos, _mm_set1_ps(1.0f)), _mm_set1_ps(1.0f)));
    const __m128 t = _mm_mul_ps(_mm_max_ps(x, _mm_set1_ps(-126.0f)), _mm_set1_ps(1.44269504f));
    __m128i n = _mm_cvttps_epi32(t);  // towards zero; t <= 0, so floor(t) is n or n - 1
    n = _mm_add_epi32(n, _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(n), t)));  // (true = -1)
    const __m128 f = _mm_sub_ps(t, _mm_cvtepi32_ps(n));
    __m128 p = _mm_add_ps(_mm_set1_ps(0.2244036f), _mm_mul_ps(f, _mm_set1_ps(0.0794772f)));
    p = _mm_add_ps(_mm_set1_ps(0.6960656f), _mm_mul_ps(f, p));
    p = _mm_add_ps(_mm_set1_ps(1.0f), _mm_mul_ps(f, p));
    return _mm_mul_ps(p, _mm_castsi128_ps(_mm_slli_epi32(_mm_add_epi32(n, _mm_set1_epi32(127)), 23)));
}
#else
inline float lobe_weight(float cos, float k) {
    const float t = std::max(k * (std::min(cos, 1.0f) - 1.0f), -126.0f) * 1.44269504f;
    int32_t n = int32_t(t);
    n -= float(n) > t ? 1 : 0;
    const float f = t - float(n);
    const float p = 1.0f + f * (0.6960656f + f * (0.2244036f + f * 0.0794772f));
    const int32_t bits = (n + 127) << 23;
    float scale;
    std::memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}
#endif
}  // namespace

void Guide::fill_block_mass(size_t c) {
    if (block_mass_.empty()) return;
    constexpr int B = kProductBlocks;
    constexpr double kInvTotal2 = 1.0 / (double(packed_map::kRowTotal) * double(packed_map::kRowTotal));
    const int R = atlas_.resolution, b = R / B;
    // From the packed map's own counts, so that the product's Z matches what it samples.
    for (int bj = 0; bj < B; ++bj)
        for (int bi = 0; bi < B; ++bi) {
            uint64_t m = 0;
            uint32_t start;
            for (int j = bj * b; j < (bj + 1) * b; ++j) m += run_weight(map(int(c)), R, j, bi * b, b, &start);
            block_mass_[c * B * B + size_t(bj * B + bi)] = float(double(m) * kInvTotal2);
        }
}

bool Guide::product(int c, Vec3 axis, float sharpness, Product* out) const {
    if (block_mass_.empty()) return false;
    constexpr int B = kProductBlocks;
    const Vec3 a = frame(c).to_local(axis);
    const float* mass = &block_mass_[size_t(c) * B * B];
#if defined(__SSE2__)
    const __m128 ax = _mm_set1_ps(a.x), ay = _mm_set1_ps(a.y), az = _mm_set1_ps(a.z), k = _mm_set1_ps(sharpness);
    __m128 zs = _mm_setzero_ps();
    for (int K = 0; K < B * B; K += 4) {
        const __m128 cos = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_loadu_ps(block_x_ + K), ax), _mm_mul_ps(_mm_loadu_ps(block_y_ + K), ay)),
                                      _mm_mul_ps(_mm_loadu_ps(block_z_ + K), az));
        const __m128 e = lobe_weight(cos, k);
        _mm_storeu_ps(out->e + K, e);
        zs = _mm_add_ps(zs, _mm_mul_ps(_mm_loadu_ps(mass + K), e));
    }
    float lanes[4];
    _mm_storeu_ps(lanes, zs);
    const float z = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
#else
    float z = 0;
    for (int K = 0; K < B * B; ++K) {
        out->e[K] = lobe_weight(block_x_[K] * a.x + block_y_[K] * a.y + block_z_[K] * a.z, sharpness);
        z += mass[K] * out->e[K];
    }
#endif
    if (!(z > 0) || !std::isfinite(z)) return false;
    out->cache = c;
    out->inv_z = 1.0f / z;
    return true;
}

void Guide::product_block(Product* p, float ux) const {
    constexpr int B = kProductBlocks;
    const float* mass = &block_mass_[size_t(p->cache) * B * B];
    // The block, by m_K e_K, then ux rescaled inside the block's interval. (Where rounding leaves ux
    // past the last interval, the last block with weight takes it.)
    float v = packed_map::clamp_unit(ux) / p->inv_z;
    int K = -1, last = 0;
    for (int k = 0; k < B * B; ++k) {
        const float w = mass[k] * p->e[k];
        if (!(w > 0)) continue;
        last = k;
        if (v < w) {
            K = k;
            v /= w;
            break;
        }
        v -= w;
    }
    if (K < 0) K = last, v = 1.0f;
    p->block = K;
    p->u_block = std::min(v, 0x1.fffffep-1f);
    const int b = atlas_.resolution / B;
    for (int j = (K / B) * b; j < (K / B + 1) * b; ++j) packed_map::prefetch_row(map(p->cache), atlas_.resolution, j);
}

Vec3 Guide::sample_product(const Product& p, float uy, float* pdf, int* texel) const {
    using namespace packed_map;
    constexpr int B = kProductBlocks;
    constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;
    const int R = atlas_.resolution, b = R / B;
    const int i0 = (p.block % B) * b, j0 = (p.block / B) * b;
    // The texel inside the block by the map's counts (texel k's probability is its row's count times
    // its own, packed_map.h): a row of the block by its count times its texels' counts in the block,
    // then the texel within that row's run of cumulative counts; uy rescaled inside its interval.
    const unsigned char* m = map(p.cache);
    uint64_t weight[kMaxResolution / kProductBlocks];  // per row of the block (run_weight)
    uint32_t start[kMaxResolution / kProductBlocks];   // the row's cumulative count before the run
    uint64_t total = 0;
    for (int r = 0; r < b; ++r) total += weight[r] = run_weight(m, R, j0 + r, i0, b, &start[r]);
    // (Where rounding leaves v past the last row with weight, that row takes it, at its end.)
    double v = double(clamp_unit(uy)) * double(total);
    int r = -1, last = 0;
    for (int q = 0; q < b; ++q) {
        if (weight[q] == 0) continue;
        last = q;
        if (v < double(weight[q])) {
            r = q;
            break;
        }
        v -= double(weight[q]);
    }
    if (r < 0) r = last, v = double(weight[r]) * double(kOneMinusEpsilon);
    const int j = j0 + r;
    uint32_t lo;
    const uint32_t row = interval(row_end(m), j, &lo);
    // The count position in the row: start + v / row, in [start, start + the run's counts).
    const double t = double(start[r]) + v / double(row);
    const uint16_t* te = texel_end(m, R, j);
    int i = i0;
    while (i < i0 + b - 1 && double(te[i]) <= t) ++i;
    const uint32_t t_lo = i > 0 ? te[i - 1] : 0u, count = uint32_t(te[i]) - t_lo;
    const float fx = count > 0 ? std::min(float((t - double(t_lo)) / double(count)), kOneMinusEpsilon) : 0.5f;
    Texel dt;  // the texel whose density applies
    const Vec3 local = sphere_point_in_texel(i, j, fx, p.u_block, R, &dt.i, &dt.j);
    *pdf = product_pdf(p, dt);
    if (IRIS_MUTANT(product_pdf_scale)) *pdf *= 1.1f;
    if (texel) *texel = texel_index(dt);
    return frame(p.cache).to_world(local);
}

Vec3 Guide::sample(int c, Vec2 u, int row, float* pdf, int* texel) const {
    float p;
    const Vec3 local = at_resolution([&](auto R) { return packed_map::sample(map(c), R, u, row, per_sr_, &p, texel); });
    if (IRIS_MUTANT(cache_pdf_scale)) p *= 1.1f;
    if (pdf) *pdf = p;
    return frame(c).to_world(local);
}

RefitSummary Guide::refit(const PathSamples& s) {
    if (!learning()) throw std::logic_error("Guide::refit needs a guide built with GuideOptions::learn");
    const size_t n = atlas_.size(), N = atlas_.texels();
    if (s.caches() != n || s.texels() != N) throw std::logic_error("Guide::refit: path samples of another atlas");
    const int R = atlas_.resolution;
    const BsdfFractionChooser chooser(std::max(R, 1), std::min(atlas_.floor, 0.999), 0.2f);
    const double floor = atlas_.floor;
    // The fill-caches filter: filter_sigma texels, as an angle on the sphere.
    const bool filtered = atlas_.filter_sigma > 0;
    const SphereFilter filter(R, float(filtered ? atlas_.filter_sigma * std::sqrt(4.0 * M_PI / double(N)) : 0.0));
    std::atomic<size_t> refit{0};
    tbb::enumerable_thread_specific<SphereMap> scratch([&] { return SphereMap(R); });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16), [&](const tbb::blocked_range<size_t>& range) {
        SphereMap& m = scratch.local();
        std::vector<float> cdf(N), pdf(N);
        for (size_t c = range.begin(); c != range.end(); ++c) {
            const uint32_t count = s.count(c);
            if (count < kMinPathSamples || count == path_used_[c]) continue;
            m.clear();
            double path_total = 0;  // (in double, as PathSamples::effective_count sums)
            for (size_t k = 0; k < N; ++k) {
                const double v = s.sum(c, k);
                m[int(k)] = float(v);
                path_total += v;
            }
            if (!(path_total > 0)) continue;  // only zero-radiance samples so far: keep the photons' map
            if (filtered) m.filter(filter);
            // Mixed by what each histogram is worth: photons (of about equal power in a cache) as
            // photon_count, path samples as their effective count (PathSamples::effective_count); the
            // photon histogram is all zeros where unusable.
            const double photons = atlas_.usable[c] ? double(atlas_.photon_count[c]) : 0.0;
            const double n_eff = s.effective_count(c, path_total);
            const double lambda = n_eff / (n_eff + photons);
            const double total = m.total();
            const float* photon = &photon_pmf_[c * N];
            for (size_t k = 0; k < N; ++k)
                m[int(k)] = float(lambda * double(m[int(k)]) / total + (1 - lambda) * double(photon[k]));
            m.normalise_floor(float(floor));
            SphereDistribution::build(m.data(), R, cdf.data(), pdf.data());
            const double omega = 4.0 * M_PI / double(N);
            for (size_t k = 0; k < N; ++k) current_pmf_[c * N + k] = float(double(pdf[k]) * omega);
            // A map worth fewer than kMinPathSamples samples in all does not guide (as fill-caches leaves
            // a cache with too few photons unusable): a histogram of a handful of heavy samples is a few
            // spikes, which the chooser would take for a sharply peaked distribution worth guiding with.
            const float alpha = photons + n_eff >= double(kMinPathSamples) ? choose_alpha(chooser, pdf.data()) : 1.0f;
            unsigned char* dst = table_.get() + c * stride_;
            reinterpret_cast<float*>(dst)[kAlpha] = alpha;
            reinterpret_cast<float*>(dst)[kRecord] = photons + n_eff >= kSaturatedSamples ? 0.0f : 1.0f;
            packed_map::encode(pdf.data(), R, dst + kHeader * sizeof(float));
            fill_block_mass(c);
            path_used_[c] = count;
            path_effective_[c] = float(n_eff);
            refit += 1;
        }
    });
    summarise_guiding();
    RefitSummary r;
    r.refit = refit.load();
    r.guiding = summary_.guiding;
    for (size_t c = 0; c < n; ++c) r.saturated += records(int(c)) ? 0 : 1;
    return r;
}

CacheAtlas Guide::refined_atlas() const {
    if (!learning()) throw std::logic_error("Guide::refined_atlas needs a guide built with GuideOptions::learn");
    CacheAtlas a = atlas_;
    const size_t n = a.size(), N = a.texels();
    a.pdf.assign(n * N, 0.0f);
    a.cdf.assign(n * N, 0.0f);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t c = range.begin(); c != range.end(); ++c) {
            // The current pmf is already floored: build() only normalises it and writes both tables.
            SphereDistribution::build(&current_pmf_[c * N], a.resolution, &a.cdf[c * N], &a.pdf[c * N]);
            // A cache refit from enough samples in all (photons and the path samples' effective
            // count) is usable; its photon_count holds both, the weight a later learn=on render gives it.
            const double photons = a.usable[c] ? double(a.photon_count[c]) : 0.0;
            if (path_used_[c] > 0 && photons + path_effective_[c] >= double(kMinPathSamples)) {
                a.usable[c] = 1;
                a.photon_count[c] = uint32_t(std::lround(photons + path_effective_[c]));
            }
        }
    });
    return a;
}

std::string describe(const RefitSummary& r, int refits, double seconds) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%d refits from path samples (%.3f s), %zu caches refit, %zu guiding, %zu saturated",
                  refits, seconds, r.refit, r.guiding, r.saturated);
    return buf;
}

}  // namespace iris
