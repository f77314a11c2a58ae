#include "formats/photon_map.h"

#include <cmath>
#include <cstdint>

namespace iris {

double caustic_power_share(const PhotonMap& m) {
    if (m.caustic.size() != m.size()) return -1;
    double all = 0, caustic = 0;
    for (size_t i = 0; i < m.size(); ++i) {
        const double p = luminance(m.power[i]);
        all += p;
        if (m.caustic[i]) caustic += p;
    }
    return all > 0 ? caustic / all : 0.0;
}

std::string validate_photon_map(const PhotonMap& m) {
    const size_t n = m.size();
    for (auto [name, rows] : {std::pair{"direction", m.direction.size()}, std::pair{"power", m.power.size()},
                              std::pair{"normal", m.normal.size()}})
        if (std::string e = h5::check_rows(name, rows, "position", n); !e.empty()) return e;
    if (!m.bounces.empty())
        if (std::string e = h5::check_rows("bounces", m.bounces.size(), "position", n); !e.empty()) return e;
    if (!m.caustic.empty()) {
        if (std::string e = h5::check_rows("caustic", m.caustic.size(), "position", n); !e.empty()) return e;
        for (size_t i = 0; i < n; ++i)
            if (m.caustic[i] > 1) return "dataset 'caustic' has the value " + std::to_string(m.caustic[i]) +
                                         " in row " + std::to_string(i) + " (0 or 1)";
    }
    if (std::string e = h5::check_finite("position", m.position); !e.empty()) return e;
    if (std::string e = h5::check_unit("direction", m.direction); !e.empty()) return e;
    if (std::string e = h5::check_unit("normal", m.normal); !e.empty()) return e;
    for (size_t i = 0; i < n; ++i) {
        const RGB& p = m.power[i];
        if (!is_finite(p)) return "dataset 'power' has a non-finite value in row " + std::to_string(i);
        if (p.r < 0 || p.g < 0 || p.b < 0) return "dataset 'power' has a negative value in row " + std::to_string(i);
        // A float-rounding margin: the writer orients the normal by this very sign.
        if (dot(m.direction[i], m.normal[i]) < -1e-3f)
            return "photon " + std::to_string(i) +
                   ": 'normal' faces away from 'direction' (the normal must face the side the photon came from)";
    }
    if (n > 0 && m.emitted_paths == 0) return "attribute 'emitted_paths' is 0 but there are photons";
    if (m.max_depth < -1) return "attribute 'max_depth' is " + std::to_string(m.max_depth) + " (-1 = unlimited)";
    return {};
}

void write_photon_map(const std::string& path, const PhotonMap& map, const std::string& scene_fingerprint,
                      const Provenance& provenance) {
    if (std::string e = validate_photon_map(map); !e.empty()) throw StageFileError(path + ": refusing to write: " + e);
    h5::Writer w(path, kPhotonMapFormat, kPhotonMapVersion, scene_fingerprint, provenance);
    w.attribute_u64("photon_count", map.size());
    w.attribute_u64("emitted_paths", map.emitted_paths);
    w.attribute_i32("max_depth", map.max_depth);
    w.dataset("position", map.position, "world units", "hit point of the photon");
    w.dataset("direction", map.direction, "unit vector",
              "incident direction omega_i: from the hit point back towards where the photon came from");
    w.dataset("power", map.power, "W",
              "RGB flux: Phi_light / (emitted_paths * p_select(light)) times the path throughput");
    w.dataset("normal", map.normal, "unit vector",
              "geometric normal at the hit, facing the side the photon came from (dot(direction, normal) >= 0)");
    if (!map.bounces.empty())
        w.dataset("bounces", map.bounces, "count",
                  "surfaces the photon left before this hit (0 = direct light from an emitter), saturating at 255");
    if (!map.caustic.empty())
        w.dataset("caustic", map.caustic, "flag",
                  "1 = the path from the light passed a specular bounce (light next-event estimation cannot reach)");
    w.commit();
}

PhotonMapFile read_photon_map(const std::string& path, const std::string& expected_fingerprint) {
    h5::Reader r(path, kPhotonMapFormat, kPhotonMapVersion, expected_fingerprint);
    PhotonMapFile f;
    f.header = r.header();
    PhotonMap& m = f.photons;
    m.emitted_paths = r.attribute_uint("emitted_paths");
    int64_t depth = r.attribute_int("max_depth");
    if (depth < -1 || depth > INT32_MAX) r.fail("attribute 'max_depth' is " + std::to_string(depth) + " (-1 = unlimited)");
    m.max_depth = int(depth);
    const uint64_t count = r.attribute_uint("photon_count");
    m.position = r.vec3s("position");
    m.direction = r.vec3s("direction");
    m.power = r.rgbs("power");
    m.normal = r.vec3s("normal");
    if (r.has_dataset("bounces")) m.bounces = r.u8s("bounces");
    if (r.has_dataset("caustic")) m.caustic = r.u8s("caustic");
    if (count != m.size())
        r.fail("attribute 'photon_count' is " + std::to_string(count) + " but dataset 'position' has " +
               std::to_string(m.size()) + " rows");
    if (std::string e = validate_photon_map(m); !e.empty()) r.fail(e);
    return f;
}

StageHeader read_photon_map_header(const std::string& path, const std::string& expected_fingerprint) {
    return read_stage_header(path, kPhotonMapFormat, kPhotonMapVersion, expected_fingerprint);
}

}  // namespace iris
