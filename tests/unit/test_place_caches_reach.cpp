// place-caches reach-paths: photon caches go only where camera paths reach. On scenes/window_room
// (an envmap sun through a window; most photons land on the room's outside, where no camera path goes)
// the old placement put about half the caches outside the room; with reach paths none should be.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "formats/scene_xml.h"
#include "libcommon/scene.h"
#include "tools/place-caches/cache_placer.h"
#include "tools/trace-photons/photon_tracer.h"

namespace {

using namespace iris;

// The room's air, as scenes/window_room/make_scene.py builds it (metres): x in [0, 4] plus the
// window wall's 0.2-m thickness only inside the opening, y in [0, 2.6], z in [0, 5]. A cache is inside
// when a point 1 cm off its surface, on the side its normal faces, is in that air
// (scenes/window_room/photon_stats.py's test).
bool inside_room(Vec3 p, Vec3 n) {
    const Vec3 q = p + 0.01f * n;
    const bool in_box = q.x > 0 && q.x < 4.2f && q.y > 0 && q.y < 2.6f && q.z > 0 && q.z < 5.0f;
    const bool in_opening = q.y > 0.8f && q.y < 2.1f && q.z > 1.9f && q.z < 3.3f;
    return in_box && (q.x <= 4.0f || in_opening);
}

struct Room {
    Scene scene;
    PhotonMap photons;
};

const Room& room() {
    static const Room r = [] {
        Room s;
        SceneLoadOptions lo;
        std::vector<std::string> warnings;
        lo.warnings = &warnings;
        s.scene = load_scene(std::string(IRIS_SOURCE_DIR) + "/scenes/window_room/window_room.xml", lo);
        PhotonOptions po;
        po.paths = 20000;
        po.seed = 3;
        po.quiet = true;
        s.photons = trace_photons(s.scene, po, nullptr);
        return s;
    }();
    return r;
}

// Camera caches every 32 x 32 pixels (80 at 320 x 240), so most of the 400 are photon caches.
PlacementOptions options(int reach_paths, int threads) {
    PlacementOptions o;
    o.count = 400;
    o.camera_stride = 32;
    o.reach_paths = reach_paths;
    o.threads = threads;
    o.seed = 5;
    o.quiet = true;
    return o;
}

double outside_share(const CachePoints& c) {
    size_t out = 0;
    for (size_t i = 0; i < c.position.size(); ++i) out += !inside_room(c.position[i], c.normal[i]);
    return c.position.empty() ? 0 : double(out) / double(c.position.size());
}

TEST(PlaceCachesReach, WindowRoomCachesStayInside) {
    const Room& r = room();
    PlacementStats on, off;
    const CachePoints with = place_caches(r.scene, r.photons, options(4, 2), &on);
    const CachePoints without = place_caches(r.scene, r.photons, options(0, 2), &off);
    ASSERT_EQ(with.position.size(), 400u);
    ASSERT_EQ(without.position.size(), 400u);
    // Old behaviour: every photon a candidate, so caches follow the (mostly outside) lit surfaces.
    EXPECT_EQ(off.eligible, r.photons.position.size());
    EXPECT_GT(outside_share(without), 0.3);
    // Reach paths: only the photons inside (under a fifth of them, docs/benchmarks/window_room.md) remain.
    EXPECT_GT(on.eligible, 0u);
    EXPECT_LT(double(on.eligible), 0.25 * double(r.photons.position.size()));
    EXPECT_LT(outside_share(with), 0.01);
}

TEST(PlaceCachesReach, SameCachesForAnyThreadCount) {
    const Room& r = room();
    PlacementStats s1, s2;
    const CachePoints a = place_caches(r.scene, r.photons, options(4, 1), &s1);
    const CachePoints b = place_caches(r.scene, r.photons, options(4, 2), &s2);
    EXPECT_EQ(s1.eligible, s2.eligible);
    ASSERT_EQ(a.position.size(), b.position.size());
    for (size_t i = 0; i < a.position.size(); ++i) {
        EXPECT_EQ(a.position[i].x, b.position[i].x) << i;
        EXPECT_EQ(a.position[i].y, b.position[i].y) << i;
        EXPECT_EQ(a.position[i].z, b.position[i].z) << i;
    }
}

TEST(PlaceCachesReach, NegativeReachPathsRejected) {
    const Room& r = room();
    EXPECT_THROW(place_caches(r.scene, r.photons, options(-1, 1), nullptr), std::runtime_error);
}

}  // namespace
