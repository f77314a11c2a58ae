// Path guiding from a cache atlas (the output of fill-caches): finds the cache that serves a path
// vertex and samples/evaluates its directional density. Directions cross the interface in world space;
// inside, each cache's own frame (Frame(normal), as fill-caches built it) is used for both sampling and
// evaluation, so the density reported for a direction is exactly the one it was sampled with
// (DESIGN 4.1, 4.2).
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

#include <tbb/enumerable_thread_specific.h>

#include "formats/cache_atlas.h"
#include "libcommon/math.h"
#include "libguide/packed_map.h"
#include "libcommon/point_tree.h"
#include "libcommon/rng.h"
#include "libcommon/spheremap.h"

namespace iris {

class BsdfFractionChooser;

enum class GuideMode : uint8_t {
    NeeBsdf,       // the unguided path tracer (what render does without an atlas)
    NeeCache,      // NEE + the cache in place of the BSDF's diffuse lobe (BSDF where no cache serves)
    BsdfCache,     // no NEE; one-sample mixture of BSDF and cache sampling
    NeeBsdfCache,  // NEE + one-sample mixture of BSDF and cache sampling, all MIS-combined (default)
};

// Parses "nee+bsdf" etc.; throws std::runtime_error on anything else.
GuideMode parse_guide_mode(const std::string& s);
const char* guide_mode_name(GuideMode m);

// How the probability alpha of BSDF sampling is set where a cache guides.
struct GuideOptions {
    // < 0: per cache, from the cache's own distribution (libguide/bsdf_fraction.h), and caches whose
    // predicted gain is below min_gain are not used at all (the vertex is unguided: no sampling cost).
    // In [0, 1): this constant for every usable cache (the thesis's setting; for parameter studies).
    float bsdf_fraction = -1.0f;
    float min_gain = 1.25f;
    // Hybrid caches: keep the photon maps so that refit() can mix them with the radiance the render's
    // paths receive, and let every cache that gathered photons answer lookups (with BSDF share 1 until a
    // refit makes it guide), so that paths also sample where the photons left a cache unusable or not
    // worth guiding with.
    bool learn = false;
    // Product sampling where the lobe a cache replaces is glossy (Guide::product); off: the map alone.
    bool product = true;
};

// Memory for tables that path vertices read or write at random (megabytes; every access would otherwise
// also miss the TLB): 2 MiB-aligned (the huge page size on x86-64) and advised for transparent huge
// pages. Not initialised.
struct FreeHuge {
    void operator()(void* p) const;
};
using HugeMemory = std::unique_ptr<unsigned char[], FreeHuge>;
HugeMemory allocate_huge(size_t bytes);

// The radiance that guided path vertices received, per cache and texel of the cache's map, summed over
// the render's passes: each sample adds L_i(w) cos(theta_c) / p(w) for the continuation direction w
// (theta_c: against the cache's normal; p: the density w was sampled with), whose expectation per texel
// is the integral of L_i cos over the texel -- the quantity a photon map's flux estimates, so that the
// two can be mixed. Sums are 64-bit fixed point (kScale units of the value): integer addition does not
// depend on the order in which threads add, so the maps refit from them, and hence the image, are the
// same for any thread count.
class PathSamples {
    // One thread's part (see Writer).
    struct Local {
        explicit Local(size_t caches) : count(caches, 0), max(caches, 0) {}
        std::vector<uint32_t> count;  // samples per cache
        std::vector<uint64_t> max;    // largest sample per cache (kScale units)
    };

public:
    PathSamples(size_t caches, size_t texels)
        : texels_(texels), caches_(caches), memory_(allocate_huge(std::max<size_t>(1, caches * texels) * sizeof(Sum))),
          sum_(reinterpret_cast<Sum*>(memory_.get())), local_([caches] { return Local(caches); }) {
        for (size_t k = 0; k < caches * texels; ++k) new (&sum_[k]) Sum(0);
    }
    PathSamples(const PathSamples&) = delete;
    PathSamples& operator=(const PathSamples&) = delete;
    static constexpr double kScale = 4294967296.0;  // 2^32 units per unit of value
    // Values above this are clamped (the map is only a guide; 2^16 x kScale x 2^15 samples fits 64 bits).
    static constexpr float kMaxValue = 65536.0f;

    // What one thread adds: each sample's value to the shared histograms (atomic), and its count and
    // largest sample per cache to the thread's own arrays (a cache's counter, shared, would bounce
    // between the cores' caches at every sample: deep vertices of all threads land in the same caches).
    // Take one per path (writer() looks the thread up).
    class Writer {
    public:
        void add(int cache, int texel, float value) {
            const float v = value > 0 ? std::min(value, kMaxValue) : 0.0f;  // NaN -> 0
            const uint64_t u = uint64_t(double(v) * kScale + 0.5);
            s_->sum_[size_t(cache) * s_->texels_ + size_t(texel)].fetch_add(u, std::memory_order_relaxed);
            local_->count[size_t(cache)] += 1;
            local_->max[size_t(cache)] = std::max(local_->max[size_t(cache)], u);
        }
        // Starts loading, for writing, the histogram line add(cache, texel, ...) will update: a vertex
        // knows its texel when it samples its continuation and adds at the end of the path, by which
        // time the line (one of megabytes of histograms, rarely in the CPU's caches) has arrived.
        void prefetch(int cache, int texel) const {
            __builtin_prefetch(&s_->sum_[size_t(cache) * s_->texels_ + size_t(texel)], 1);
        }

    private:
        friend class PathSamples;
        Local* local_ = nullptr;
        PathSamples* s_ = nullptr;
    };
    Writer writer() {
        Writer w;
        w.local_ = &local_.local();
        w.s_ = this;
        return w;
    }

    // Read between passes (no thread adding): the sums over threads -- integer sums and a maximum,
    // which do not depend on the order in which threads added.
    uint32_t count(size_t cache) const {
        uint32_t n = 0;
        for (const Local& l : local_) n += l.count[cache];
        return n;
    }
    double sum(size_t cache, size_t texel) const {
        return double(sum_[cache * texels_ + texel].load(std::memory_order_relaxed)) / kScale;
    }
    double max(size_t cache) const {
        uint64_t m = 0;
        for (const Local& l : local_) m = std::max(m, l.max[cache]);
        return double(m) / kScale;
    }
    // How many samples cache c's histogram is worth: the count of equal-weight samples with the same
    // total, sum / max, a lower bound of the effective sample size (sum)^2 / sum of squares. A path
    // sample is L_i cos / p of one path: heavy-tailed (the rare path through a small opening carries
    // most of the total), and after a few passes one or two samples make the whole histogram; counted
    // as their number, they outweighed hundreds of photons (docs/benchmarks/hybrid.md).
    double effective_count(size_t cache) const {
        double total = 0;
        for (size_t k = 0; k < texels_; ++k) total += sum(cache, k);
        return effective_count(cache, total);
    }
    // The same where the caller has the cache's total (the sum of sum(cache, k) over its texels).
    double effective_count(size_t cache, double total) const {
        const double m = max(cache);
        return m > 0 ? std::min(double(count(cache)), total / m) : 0.0;
    }
    size_t texels() const { return texels_; }
    size_t caches() const { return caches_; }

private:
    using Sum = std::atomic<uint64_t>;
    static_assert(std::is_trivially_destructible_v<Sum>);
    size_t texels_, caches_;
    HugeMemory memory_;  // the histograms: caches x texels sums, kScale units
    Sum* sum_;
    tbb::enumerable_thread_specific<Local> local_;
};

// What a refit changed.
struct RefitSummary {
    size_t refit = 0;    // caches whose map now includes path samples
    size_t guiding = 0;  // caches that guide after it
    size_t saturated = 0;  // caches that no longer record path samples (Guide::records)
};
// "N refits from path samples (S s), ..." for the render's metadata and its report.
std::string describe(const RefitSummary& r, int refits, double seconds);

// What the guide decided at load time, for the render's report.
struct GuideSummary {
    size_t caches = 0;         // in the atlas
    size_t usable = 0;         // with enough photons (fill-caches)
    size_t guiding = 0;        // used by the renderer: usable and, in the adaptive setting, worth it
    double mean_alpha = 1.0;   // mean BSDF share over the guiding caches
    size_t table_bytes = 0;    // the maps as the renderer holds them (packed, with their headers)
    size_t grid_bytes = 0;     // the lookup grids' slots (fine and coarse)
};

class Guide {
public:
    Guide(CacheAtlas atlas, const GuideOptions& options);
    // Constant BSDF fraction alpha in [0, 1) for every usable cache (no per-cache choice).
    Guide(CacheAtlas atlas, float bsdf_fraction) : Guide(std::move(atlas), GuideOptions{bsdf_fraction, 1.0f}) {}

    // The guiding cache for a vertex at p whose surface side (the side the path arrives from) has
    // normal n_side, or -1 for an unguided vertex. A cache serves a point when it lies within the
    // cache's gather radius (times a slack) and the cache's normal within 45 degrees of the point's.
    // The vertex takes the answer of its cell for the axis nearest n_side (normal_class): the cache
    // nearest the cell's centre, among the kAnswerCandidates nearest it, that serves some point of the
    // cell with that axis as its normal. The cell is p's cell of the fine grid (cells about two cache
    // spacings wide, within half a cell of every cache), or else of the coarse grid (cells four times as wide,
    // wherever some cache serves a point); outside both no cache serves p. So the choice is a fixed
    // function of (p, n_side), as unbiased MIS requires, and -1 where the chosen cache does not guide
    // (too few photons, or a predicted gain below min_gain) or none serves.
    // Starts loading the cache's sampling table into the CPU cache.
    int lookup(Vec3 p, Vec3 n_side) const { return lookup(probe(p), n_side); }

    // The same in two steps, so that the integrator can start loading the grid slots as soon as it
    // knows the vertex and read them later: probe(p) finds p's cells in both grids (their keys and
    // first slots; each hashed once) and starts loading their slots; lookup(probe, n_side) reads them.
    struct CellRef {
        uint64_t key = ~0ull;  // ~0: p is outside the grid
        size_t slot = 0;       // where the cell's probe sequence starts
    };
    struct Probe {
        CellRef fine, coarse;
    };
    // (A p that is not finite is in neither grid: Grid::cell_of's range test fails for NaN and inf.)
    Probe probe(Vec3 p) const { return {fine_.cell_ref(p), coarse_.cell_ref(p)}; }
    int lookup(const Probe& q, Vec3 n_side) const;
    // Which of the six axis directions (+x, -x, +y, -y, +z, -z: 0..5) is nearest n.
    // (Without branches: a path's vertices land on walls of every orientation, and branches on the
    // normal mispredicted about once per lookup.)
    static int normal_class(Vec3 n) {
        const float ax = std::abs(n.x), ay = std::abs(n.y), az = std::abs(n.z);
        const int z = int(az >= ax) & int(az >= ay);  // ties go to z, then to y
        const int y = (z ^ 1) & int(ay >= ax);
        const int x = (z | y) ^ 1;
        const int negative = (z & int(n.z < 0)) | (y & int(n.y < 0)) | (x & int(n.x < 0));
        return 2 * (2 * z + y) + negative;
    }
    // The centre and width of the cell whose answer p takes (fine grid, else coarse); false where p is
    // in neither grid (no cache serves it).
    bool cell_center(Vec3 p, Vec3* center, float* width) const;
    // Caches (nearest the cell's centre first) among which a cell's answers are chosen.
    static constexpr uint32_t kAnswerCandidates = 32;

    // Samples a world-space direction from cache c; *pdf receives its density per steradian.
    Vec3 sample(int c, Vec2 u, float* pdf) const { return sample(c, u, sample_row(c, u), pdf); }
    // The same in two steps: the row of cache c's map that u picks (its row counts are read now) and
    // the start of loading that row's texel counts, then the sample, which searches only that row.
    int sample_row(int c, Vec2 u) const {
        return at_resolution([&](auto R) {
            const int j = packed_map::row_of(map(c), R, u.x);
            packed_map::prefetch_row(map(c), R, j);
            return j;
        });
    }
    // (texel, where given, receives the sampled direction's texel index j R + i, as texel_index().)
    Vec3 sample(int c, Vec2 u, int row, float* pdf, int* texel = nullptr) const;
    // Density per steradian with which sample(c, ...) produces the world direction w.
    float pdf(int c, Vec3 w) const { return texel_pdf(c, texel(c, w)); }

    // The same in two steps, so that the integrator can start loading the memory a density needs
    // before it traces the shadow ray and read it after: texel of w in cache c's map, its density.
    struct Texel {
        int i, j;  // column and row
    };
    Texel texel(int c, Vec3 w) const {
        Texel t;
        at_resolution([&](auto R) { sphere_texel_of(frame(c).to_local(w), R, &t.i, &t.j); });
        return t;
    }
    float texel_pdf(int c, Texel t) const {
        return at_resolution([&](auto R) { return packed_map::texel_pdf(map(c), R, t.i, t.j, per_sr_); });
    }
    // Of texel k = j R + i.
    float texel_pdf(int c, int k) const { return packed_map::texel_pdf(map(c), atlas_.resolution, k, per_sr_); }
    void prefetch_texel(int c, Texel t) const {
        at_resolution([&](auto R) { packed_map::prefetch_row(map(c), R, t.j); });
    }
    // Product sampling with a glossy lobe (issue 25, part 2; docs/benchmarks/product.md). A map holds
    // L_i cos: for a diffuse lobe that already is the integrand, but where the lobe the cache replaces is
    // glossy (a rough conductor, Ward without a diffuse part) the integrand is that times the lobe, which
    // the map alone spreads over the whole hemisphere. The product technique weights the map by the lobe,
    // taken as constant on each of kProductBlocks^2 square blocks of texels (a spherical Gaussian
    // exp(sharpness (cos - 1)) about the lobe's axis, at the block's centre direction), so that it stays
    // piecewise constant with an exact density:
    //   p(w) = d_k e_K / Z,   Z = sum_K m_K e_K,
    // d_k: the map's density in w's texel k, e_K: the weight of k's block K, m_K: the map's probability
    // in K (kept per cache). Sampling picks a block by m_K e_K, a texel in it by d_k, a point in the
    // texel uniformly. The weight needs only be non-negative for the estimate to stay unbiased; how well
    // it follows the lobe decides the variance.
    static constexpr int kProductBlocks = 8;  // blocks per side of the map (resolutions divisible by 8)
    struct Product {
        int cache = -1;
        float inv_z = 0;      // 1 / Z
        int block = 0;        // the block product_block picked
        float u_block = 0;    // and its random number rescaled inside the block's interval
        float e[kProductBlocks * kProductBlocks];  // lobe weight per block, in (0, 1]
    };
    // The product of cache c's map with a lobe about the world direction `axis`; false where the map's
    // resolution has no blocks or the product vanishes (then the plain map guides).
    bool product(int c, Vec3 axis, float sharpness, Product* out) const;
    float product_pdf(const Product& p, Texel t) const {
        const int b = atlas_.resolution / kProductBlocks;
        return texel_pdf(p.cache, t) * p.e[(t.j / b) * kProductBlocks + t.i / b] * p.inv_z;
    }
    // Sampling in two steps, so that the integrator can start loading the rows the sample reads before
    // NEE's shadow ray and read them after: the block for ux (kept in *p; its rows start loading), then
    // the direction, by the texel in the block for uy. *pdf receives its density; texel, where given,
    // the index of the texel whose density that is (as texel_index()).
    void product_block(Product* p, float ux) const;
    Vec3 sample_product(const Product& p, float uy, float* pdf, int* texel = nullptr) const;
    // Starts loading what product(c, ...) reads of cache c (its block masses).
    void prefetch_product(int c) const {
        if (block_mass_.empty()) return;
        const float* m = &block_mass_[size_t(c) * kProductBlocks * kProductBlocks];
        for (int l = 0; l < kProductBlocks * kProductBlocks; l += 16) iris::prefetch(m + l);
    }
    // Probability of BSDF sampling at a vertex that cache c serves.
    float bsdf_fraction(int c) const { return header(c)[kAlpha]; }
    // The atlas's fields except its maps, which live in the guide's own table (below).
    const CacheAtlas& atlas() const { return atlas_; }
    const GuideSummary& summary() const { return summary_; }
    // Bytes the guide holds per cache of an atlas of resolution R (its header and packed map).
    static size_t bytes_per_cache(int R) { return kHeader * sizeof(float) + packed_map::bytes(R); }
    bool empty() const { return summary_.guiding == 0 && !learning(); }

    // Hybrid caches (GuideOptions::learn). Whether the guide keeps its photon maps for refit().
    bool learning() const { return !photon_pmf_.empty(); }
    // Texel index k = j R + i of the world direction w in cache c's map, and w's cosine against the
    // cache's normal.
    int texel_index(int c, Vec3 w) const { return texel_index(texel(c, w)); }
    int texel_index(Texel t) const { return t.j * atlas_.resolution + t.i; }
    float cos_normal(int c, Vec3 w) const { return dot(frame(c).n, w); }
    // Re-fits the map of every cache with at least kMinPathSamples samples in `s` from its photon map
    // and the path samples: the two normalised histograms mixed by what each is worth (photons counted
    // as photon_count, path samples as their effective count), the path histogram smoothed with the
    // atlas's filter, the atlas's floor mixed in, as fill-caches does; then its BSDF share is chosen
    // again (no guiding below kMinPathSamples in all) and its packed map rebuilt. Must not run while any
    // thread samples the guide (the render calls it between passes).
    RefitSummary refit(const PathSamples& s);
    static constexpr uint32_t kMinPathSamples = 32;
    // Whether a learning render still adds path samples at cache c. Recording costs a random access into
    // the samples' histograms per vertex (+27 % time per sample on the door, every vertex guided); once
    // a cache's map is worth kSaturatedSamples (photons + the path samples' effective count) further
    // samples barely move it, and the cache stops recording (decided at a refit: between passes).
    bool records(int c) const { return header(c)[kRecord] != 0; }
    static constexpr double kSaturatedSamples = 1024;
    // The atlas with the maps as they stand (photons and path samples), for render --write-atlas:
    // caches refit from enough samples are usable, and their photon_count holds photons plus the path
    // samples' effective count.
    CacheAtlas refined_atlas() const;

private:
    // Calls f with the maps' resolution: as the compile-time constant kFastResolution where the atlas
    // has it (the pipeline's default), so that the compiler unrolls the map's count searches and folds
    // its row offsets on the hot path, else as the atlas's int.
    static constexpr int kFastResolution = 32;
    template <class F>
    auto at_resolution(F&& f) const -> std::invoke_result_t<F&, int> {
        if (atlas_.resolution == kFastResolution) return f(std::integral_constant<int, kFastResolution>{});
        return f(atlas_.resolution);
    }
    // Hash grids over the space near the caches that claim vertices (all with a gather disc). Each
    // cell stores the lookup's answer for each normal class, so a lookup is one hash probe and one
    // cache line: for deep (incoherent) vertices, scanning a list of candidates per cell cost two more
    // dependent cache misses than sampling the cache itself. The fine grid covers the surfaces around
    // the caches; the caches' gather discs reach farther (k photons need discs wider than the caches'
    // spacing), and there the coarse grid answers, with far fewer cells than a fine grid that far out.
    // (It replaced a k-d tree search per vertex there: the egg's render with every vertex guided took
    // 6 % less time per sample, at the same noise; a vertex then never searches.)
    struct Slot {
        uint64_t key = ~0ull;  // ~0 = empty
        int32_t answer[6];     // cache per normal class, -1 = unguided
    };
    struct Grid {
        Vec3 origin;
        float cell = 0, inv_cell = 0;
        std::vector<Slot> slots;  // open addressing, capacity a power of two (empty: no grid)
        static uint64_t key(int64_t x, int64_t y, int64_t z) { return uint64_t(x) | (uint64_t(y) << 21) | (uint64_t(z) << 42); }
        // Integer coordinates of p's cell; false outside the grid's 2^21 cells per axis (so keys never alias).
        bool cell_of(Vec3 p, int64_t* x, int64_t* y, int64_t* z) const {
            const Vec3 q = (p - origin) * inv_cell;
            constexpr float kCells = float(1 << 21);
            if (!(q.x >= 0 && q.y >= 0 && q.z >= 0 && q.x < kCells && q.y < kCells && q.z < kCells)) return false;
            *x = int64_t(q.x), *y = int64_t(q.y), *z = int64_t(q.z);
            return true;
        }
        Vec3 center(int64_t x, int64_t y, int64_t z) const {
            return origin + Vec3(float(x) + 0.5f, float(y) + 0.5f, float(z) + 0.5f) * cell;
        }
        // p's cell (key ~0 where the grid is empty or p outside it), its slot starting to load.
        CellRef cell_ref(Vec3 p) const {
            CellRef r;
            int64_t x, y, z;
            if (!slots.empty() && cell_of(p, &x, &y, &z)) {
                r.key = key(x, y, z);
                r.slot = mix64(r.key) & (slots.size() - 1);
                iris::prefetch(&slots[r.slot]);
            }
            return r;
        }
        // The slot of the cell, or null where the cell is not in the grid.
        const Slot* find(const CellRef& r) const;
        const Slot* find(Vec3 p) const { return find(cell_ref(p)); }
    };
    // Fills g with cells of width `cell` covering the box of half-width reach[i] around every claimant i,
    // each with its answers.
    void fill_grid(Grid& g, float cell, const std::vector<float>& reach, const std::vector<uint32_t>& claimants,
                   const PointTree& tree) const;
    void build_grid(const std::vector<uint32_t>& claimants);
    // BSDF share of a cache allowed to guide whose map is pdf (N densities per sr): the constant
    // setting bsdf-fraction, else the chooser's, 1 (not guiding) where its predicted gain is below min_gain.
    float choose_alpha(const BsdfFractionChooser& chooser, const float* pdf) const;
    // summary_.guiding and mean_alpha from the caches' BSDF shares as they stand.
    void summarise_guiding();
    // The first of n candidate caches (indices into claimants) that serves some point of the box
    // [lo, hi] for a surface of this normal (-1: none).
    int first_serving(const std::vector<uint32_t>& claimants, const uint32_t* idx, uint32_t n, Vec3 lo, Vec3 hi,
                      Vec3 normal) const;
    float max_serve2_ = 0;  // largest squared serving distance of any cache
    Grid fine_, coarse_;
    CacheAtlas atlas_;
    // What a guided vertex reads of each cache, one block of stride_ bytes per cache, 64-byte aligned,
    // in huge pages where the system allows (random access to megabytes: every lookup would otherwise
    // also miss the TLB):
    //   [header: the cache's frame s, t, n (9 floats), alpha, padded to 64 bytes][its map, packed
    //    (libguide/packed_map.h): row ends, then each row's cumulative texel counts]
    // The header's line and the row ends are what every guided vertex needs (alpha 1 = not guiding),
    // adjacent so that they load together; a density or a sample then reads one row's counts.
    // kRecord: 1 where a learning render still records path samples at the cache (its header is read
    // anyway), 0 once the cache's map is worth kSaturatedSamples.
    static constexpr size_t kHeader = 16, kAlpha = 9, kRecord = 10;  // in floats
    HugeMemory table_;
    size_t stride_ = 0;  // bytes
    float per_sr_ = 0;   // N / (4 pi): texel probability -> density per steradian
    const unsigned char* block(int c) const { return table_.get() + size_t(c) * stride_; }
    const float* header(int c) const { return reinterpret_cast<const float*>(block(c)); }
    const unsigned char* map(int c) const { return block(c) + kHeader * sizeof(float); }
    Frame frame(int c) const {
        const float* h = header(c);
        Frame f;
        f.s = {h[0], h[1], h[2]};
        f.t = {h[3], h[4], h[5]};
        f.n = {h[6], h[7], h[8]};
        return f;
    }
    GuideSummary summary_;
    // Product sampling: per cache, the map's probability in each block (kProductBlocks^2 values, empty
    // where the resolution has no blocks), and the blocks' centre directions in a cache's own frame.
    std::vector<float> block_mass_;
    float block_x_[kProductBlocks * kProductBlocks], block_y_[kProductBlocks * kProductBlocks],
        block_z_[kProductBlocks * kProductBlocks];
    void fill_block_mass(size_t c);
    // With learning: per cache, the photon map as a pmf without its floor (N values summing to 1; all
    // zero for unusable caches), and the current map's pmf (floored) as the guide samples it.
    std::vector<float> photon_pmf_, current_pmf_;
    std::vector<uint32_t> path_used_;      // path samples in each cache's current map
    std::vector<float> path_effective_;    // and their effective count (PathSamples::effective_count)
    GuideOptions options_;
};

}  // namespace iris
