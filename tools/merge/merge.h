// merge-images and merge-photons: the parts of a render or of a photon map traced in separate
// processes (render --sample-range A:B, trace-photons --path-range A:B; e.g. the tasks of a Slurm job
// array, pipelines/slurm/) joined into the file one process would have written.
//
// Images: the parts' film sums (formats/film_parts.h, stored exactly) are added, and the image is
// made from them by the code render uses, so it equals the single run's except where adding the sums
// in another order rounds a double differently (then by ~1e-16 relative before the final rounding to
// float). Photon maps: the parts' photons in range order, which are the single run's bit for bit (each
// path is seeded by its index and normalised by the total count).
//
// Both refuse, with one line naming the file(s), parts of different scenes or settings, overlapping
// ranges, a range no part covers (naming it), a file that is not a part, and damaged or truncated files.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "formats/exr.h"
#include "formats/photon_map.h"

namespace iris {

struct MergeError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// A half-open range [begin, end) and the file holding it.
struct PartRange {
    uint64_t begin = 0, end = 0;
    std::string path;
};
// Checks that `parts` tile [0, total) exactly: throws MergeError naming two overlapping parts or the
// first range no part covers. `what`: "samples" or "paths".
void check_ranges(std::vector<PartRange> parts, uint64_t total, const char* what);

// Reads the render parts and returns the merged image (metadata as one run's: spp, time = the parts'
// summed seconds, rays, ... plus iris:merged naming the parts). Throws MergeError / ImageError.
Image merge_image_parts(const std::vector<std::string>& paths, const std::string& command_line);

struct MergedPhotons {
    PhotonMap photons;
    std::string scene_fingerprint;
    Provenance provenance;
};
// Reads the photon map parts and returns the merged map and its provenance (the parts' parameters,
// seconds and NaN/Inf counts summed, the caustic share of the whole map). Throws MergeError /
// StageFileError.
MergedPhotons merge_photon_parts(const std::vector<std::string>& paths, const std::string& command_line);

}  // namespace iris
