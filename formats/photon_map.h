// photons.h5, the output of trace-photons: every photon stored at a non-specular hit.
// Layout, units and conventions: formats/README.md, "iris-photon-map".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "formats/hdf5_util.h"
#include "libcommon/color.h"
#include "libcommon/math.h"

namespace iris {

inline constexpr const char* kPhotonMapFormat = "iris-photon-map";
inline constexpr int kPhotonMapVersion = 1;

// Photons as parallel arrays (structure of arrays: the k-d tree and the cache filler each touch only
// some of them). All four arrays have size().
struct PhotonMap {
    std::vector<Vec3> position;   // hit point, world units
    std::vector<Vec3> direction;  // unit; from the hit point back towards where the photon came from (omega_i)
    std::vector<RGB> power;       // flux, W: Phi_light / (N * p_select(light)) times the path throughput; >= 0
    // Unit geometric normal at the hit, facing the side the photon arrived from:
    // dot(direction, normal) >= 0. (A surface's own orientation says nothing about which side is lit.)
    std::vector<Vec3> normal;
    // Surfaces the photon left before this hit (0 = it came straight from a light, i.e. direct light;
    // saturates at 255). Optional in files (then empty): lets fill-caches leave direct light to NEE.
    std::vector<uint8_t> bounces;
    // 1 = the photon's path from the light passed a specular bounce (a Dirac lobe: glass, mirror, smooth
    // metal) before this hit: light that a path tracer gathers only when BSDF sampling happens to
    // follow the specular chain to the emitter, since next-event estimation cannot connect through it
    // -- what guiding is for. 0 or 1; optional in files (then empty).
    std::vector<uint8_t> caustic;
    uint64_t emitted_paths = 0;  // N, the number of photon paths traced (> 0 whenever photons exist)
    int max_depth = -1;          // longest photon path, in segments (light -> first hit = 1); -1 = unlimited

    size_t size() const { return position.size(); }
};

struct PhotonMapFile {
    StageHeader header;
    PhotonMap photons;
};

// "" if `map` satisfies the contract, else what is wrong (naming the dataset and row).
std::string validate_photon_map(const PhotonMap& map);

// Share of the stored photon power (luminance) whose path passed a specular bounce (the caustic flag):
// light a path tracer finds only when BSDF sampling follows the specular chain. 0 for an empty map;
// -1 when the map has no caustic flags.
double caustic_power_share(const PhotonMap& map);

// Writes atomically (see hdf5_util.h). Throws StageFileError, leaving no file, if the map is invalid.
void write_photon_map(const std::string& path, const PhotonMap& map, const std::string& scene_fingerprint,
                      const Provenance& provenance);

// Reads and validates the whole file. expected_fingerprint: the scene's fingerprint, or "" to skip the
// check. Throws StageFileError with a one-line message naming the file.
PhotonMapFile read_photon_map(const std::string& path, const std::string& expected_fingerprint = {});

// Only the root attributes (kind, version, fingerprint, provenance): no photon is loaded.
StageHeader read_photon_map_header(const std::string& path, const std::string& expected_fingerprint = {});

}  // namespace iris
