// The fill-caches stage: each cache gathers the k nearest photons on its side of the surface (within a
// radius limit), splats their power into an equal-area octahedral map of incident directions in its
// own frame, smooths it on the sphere, mixes in a floor, and stores the PDF (per steradian) and CDF.
#pragma once

#include <cstdint>

#include "formats/cache_atlas.h"
#include "formats/cache_points.h"
#include "formats/photon_map.h"

namespace iris {

struct FillOptions {
    uint32_t k = 2000;            // photons gathered per cache
    int resolution = 32;          // R: the map has R x R texels over the whole sphere (pipelines/guided.mk says why 32)
    double max_radius = 0.05;     // gather radius limit, as a fraction of the scene's bounding-box diagonal
    uint32_t min_photons = 32;    // fewer usable photons than this: the cache is marked unusable
    double filter_sigma = 0.75;   // Gaussian smoothing, standard deviation in texels (0 = no filter)
    double floor = 0.1;           // mixture weight of the uniform density (DESIGN 4.4), in [0, 1]
    // Leave out photons that came straight from a light: where the renderer does next-event estimation,
    // direct light is already sampled well, and the caches should spend their samples on the indirect
    // light (caustics above all). Needs the photon map's `bounces` dataset.
    bool direct = false;
    double normal_cos = 0.8;      // photons count only where their surface normal is this close to the cache's
    int threads = 0;
    bool quiet = false;
};

struct FillStats {
    uint32_t usable = 0, unusable = 0;
    double mean_photons = 0, mean_radius = 0, seconds = 0;
};

// Throws std::runtime_error naming the setting of the first option out of range (fill_caches checks too;
// the tool calls it before reading its inputs).
void check_fill_options(const FillOptions& opts);

// scene_diagonal: length of the scene's bounding-box diagonal (world units), for the radius limit.
CacheAtlas fill_caches(const CachePoints& caches, const PhotonMap& photons, double scene_diagonal,
                       const FillOptions& opts, FillStats* stats);

}  // namespace iris
