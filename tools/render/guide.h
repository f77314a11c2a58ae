// Path guiding from a cache atlas (the output of fill-caches): finds the cache that serves a path
// vertex and samples/evaluates its directional density. Directions cross the interface in world space;
// inside, each cache's own frame (Frame(normal), as fill-caches built it) is used for both sampling and
// evaluation, so the density reported for a direction is exactly the one it was sampled with
// (DESIGN 4.1, 4.2).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "formats/cache_atlas.h"
#include "libcommon/math.h"
#include "libcommon/point_tree.h"

namespace iris {

enum class GuideMode : uint8_t {
    NeeBsdf,       // the unguided path tracer (what render does without an atlas)
    NeeCache,      // NEE + continuation from the cache only (BSDF fallback where no cache serves)
    BsdfCache,     // no NEE; one-sample mixture of BSDF and cache sampling
    NeeBsdfCache,  // NEE + one-sample mixture of BSDF and cache sampling, all MIS-combined (default)
};

// Parses "nee+bsdf" etc.; throws std::runtime_error on anything else.
GuideMode parse_guide_mode(const std::string& s);
const char* guide_mode_name(GuideMode m);

class Guide {
public:
    // bsdf_fraction: probability alpha of BSDF sampling in the mixture modes (DESIGN 4.3), in (0, 1).
    Guide(CacheAtlas atlas, float bsdf_fraction);

    // The cache serving a vertex at p whose surface side (the side the path arrives from) has normal
    // n_side, or -1. The nearest usable cache within a distance of its own gather radius (times a
    // slack) whose normal is within ~45 degrees of n_side.
    int lookup(Vec3 p, Vec3 n_side) const;

    // Samples a world-space direction from cache c; *pdf receives its density per steradian.
    Vec3 sample(int c, Vec2 u, float* pdf) const {
        Vec3 local = sample_local(c, u, pdf);
        return frames_[size_t(c)].to_world(local);
    }
    // Density per steradian with which sample(c, ...) produces the world direction w.
    float pdf(int c, Vec3 w) const;
    float bsdf_fraction(int c) const { return alpha_; }
    const CacheAtlas& atlas() const { return atlas_; }
    size_t usable_count() const { return usable_positions_.size(); }

private:
    // A hash grid over the usable caches: the cell of a vertex lists the caches inside it, contiguous in
    // memory with what the test needs, so most lookups cost one hash probe and a short scan instead of
    // a k-d tree descent. Vertices whose cell has no serving cache fall back to the tree.
    struct GridEntry {
        Vec3 position;
        Vec3 normal;
        float radius2;   // squared distance the cache may serve
        uint32_t cache;  // index into the atlas
    };
    void build_grid();
    int lookup_grid(Vec3 p, Vec3 n_side) const;
    int lookup_tree(Vec3 p, Vec3 n_side) const;
    uint64_t cell_key(Vec3 p) const;
    float cell_size_ = 0, inv_cell_ = 0;
    Vec3 grid_origin_;
    std::vector<GridEntry> entries_;              // grouped by cell
    std::vector<uint64_t> slot_key_;              // open addressing, capacity a power of two; ~0 = empty
    std::vector<uint32_t> slot_begin_, slot_end_; // entries_ range of each slot's cell
    void prefetch(int c) const;
    Vec3 sample_local(int c, Vec2 u, float* pdf) const;
    CacheAtlas atlas_;
    std::vector<Frame> frames_;
    std::vector<Vec3> usable_positions_;
    std::vector<uint32_t> usable_ids_;
    std::vector<float> lookup_radius2_;  // per usable cache: squared distance it may serve
    std::unique_ptr<PointTree> tree_;
    float alpha_;
};

}  // namespace iris
