// Stress: rays leaving a surface never hit that surface again, and visibility between two surface
// points is right, at scene scales 1e-3 .. 1e4 and far from the origin (libcommon/scene.h:
// offset_ray_origin, spawn_ray, Scene::intersect, Scene::occluded).
//
// Guards against self-intersection ("shadow acne", paths trapped on or leaking through a surface) and
// against offsets so large that they change the image: both are what a fixed, absolute epsilon does at
// some scale. Surface points are real hits of Scene::intersect (so they carry the renderer's actual
// rounding), on triangles of every shape (slivers included) and on analytic spheres, from both sides.
// Each point spawns rays in random directions with the renderer's own offsetting and checks that
//   - the first hit is never the starting triangle, nor the starting sphere at t ~ 0 (a ray into a
//     sphere must reach its far side);
//   - a ray leaving the inside of a closed box always hits something;
// and pairs of surface points check Scene::occluded against the exact (double) answer: open segments
// are not blocked, a segment from a point offset to the far side of its own wall is.
// The offset itself must stay small: below a few hundred ULPs of the point's coordinates plus 1e-4 of
// the scene's size (an absolute offset would be a visible fraction of a millimetre-sized scene).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "libcommon/rng.h"
#include "libcommon/scene.h"

using namespace iris;

namespace {

struct Layout {
    double s, shift;  // scale, and translation in units of the scene's size
    const char* name;
};

const Layout kLayouts[] = {
    {1e-3, 0, "s=1e-3"},       {1, 0, "s=1"},          {1e4, 0, "s=1e4"},
    {1, 1e3, "s=1,shift=1e3"}, {1e-3, 1e4, "s=1e-3,shift=1e4"}, {1e4, 1e2, "s=1e4,shift=1e2"},
};

struct World {
    Scene scene;
    double s;
    Vec3 off;
    Vec3 to_world(double x, double y, double z) const {
        return Vec3(float(s * x + off.x), float(s * y + off.y), float(s * z + off.z));
    }
};

double rnd(Rng& r, double a, double b) { return a + (b - a) * r.next_double(); }

Vec3 random_unit(Rng& r) {
    const double z = 1 - 2 * r.next_double(), phi = 2 * M_PI * r.next_double();
    const double q = std::sqrt(std::max(0.0, 1 - z * z));
    return Vec3(float(q * std::cos(phi)), float(q * std::sin(phi)), float(z));
}

// Mesh 0: the closed box [-1,1]^3, normals inwards. Mesh 1 (if shards): random triangles inside it,
// from well-shaped to slivers of aspect 1e-4. Spheres: inside the box.
World make_world(const Layout& L, bool shards, uint64_t seed) {
    World w;
    w.s = L.s;
    w.off = Vec3(float(L.s * L.shift), float(-0.7 * L.s * L.shift), float(0.4 * L.s * L.shift));
    Scene& sc = w.scene;
    sc.bsdfs.push_back(Bsdf{});
    Mesh box;
    box.name = "box";
    for (int i = 0; i < 8; ++i) box.positions.push_back(w.to_world(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
    // Faces as quads (a b c d), corners in order around the face.
    const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        // Wind each face so that its normal points into the box (towards the centre).
        const Vec3 a = box.positions[q[0]], b = box.positions[q[1]], c = box.positions[q[2]];
        const Vec3 mid = (a + c) * 0.5f, centre = w.to_world(0, 0, 0);
        const bool inward = dot(cross(b - a, c - a), centre - mid) > 0;
        if (inward)
            box.indices.insert(box.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
        else
            box.indices.insert(box.indices.end(), {q[0], q[2], q[1], q[0], q[3], q[2]});
    }
    sc.meshes.push_back(box);
    Rng rng = Rng::for_index(seed, Stream::Test, 0);
    if (shards) {
        Mesh m;
        m.name = "shards";
        for (int t = 0; t < 96; ++t) {
            double c[3] = {rnd(rng, -0.7, 0.7), rnd(rng, -0.7, 0.7), rnd(rng, -0.7, 0.7)};
            Vec3 a = random_unit(rng), b = random_unit(rng);
            double len = rnd(rng, 0.05, 0.4), thin = t % 4 == 0 ? 1e-4 : (t % 4 == 1 ? 1e-2 : 1.0);
            double bb = len * thin;
            uint32_t base = uint32_t(m.positions.size());
            m.positions.push_back(w.to_world(c[0], c[1], c[2]));
            m.positions.push_back(w.to_world(c[0] + len * a.x, c[1] + len * a.y, c[2] + len * a.z));
            m.positions.push_back(w.to_world(c[0] + 0.5 * len * a.x + bb * b.x, c[1] + 0.5 * len * a.y + bb * b.y,
                                             c[2] + 0.5 * len * a.z + bb * b.z));
            // Skip triangles that float rounding made degenerate (the loader drops those too).
            Vec3 n = cross(m.positions[base + 1] - m.positions[base], m.positions[base + 2] - m.positions[base]);
            if (!(length(n) > 0)) {
                m.positions.resize(base);
                continue;
            }
            m.indices.insert(m.indices.end(), {base, base + 1, base + 2});
        }
        // Large tilted triangles through the box's centre (the origin when unshifted): points near the
        // origin carry the rounding of the far-away vertices, not of their own small coordinates.
        for (int t = 0; t < 4; ++t) {
            Vec3 a = random_unit(rng), b = normalize(cross(a, random_unit(rng)));
            uint32_t base = uint32_t(m.positions.size());
            m.positions.push_back(w.to_world(0.9 * a.x, 0.9 * a.y, 0.9 * a.z));
            m.positions.push_back(w.to_world(-0.45 * a.x + 0.8 * b.x, -0.45 * a.y + 0.8 * b.y, -0.45 * a.z + 0.8 * b.z));
            m.positions.push_back(w.to_world(-0.45 * a.x - 0.8 * b.x, -0.45 * a.y - 0.8 * b.y, -0.45 * a.z - 0.8 * b.z));
            m.indices.insert(m.indices.end(), {base, base + 1, base + 2});
        }
        sc.meshes.push_back(m);
    }
    const double sph[4][4] = {{0.3, 0.2, -0.4, 0.35}, {-0.5, -0.4, 0.3, 0.2}, {-0.2, 0.55, 0.5, 0.12}, {0.6, -0.6, -0.6, 0.3}};
    for (const auto& p : sph) {
        Sphere S;
        S.center = w.to_world(p[0], p[1], p[2]);
        S.radius = float(p[3] * L.s);
        sc.spheres.push_back(S);
    }
    sc.finalize();
    return w;
}

bool same_prim(const SurfaceHit& a, const SurfaceHit& b) { return a.geom == b.geom && a.prim == b.prim; }

// A real surface hit: cast from a random point inside the box in a random direction.
bool random_hit(const World& w, Rng& rng, SurfaceHit* h) {
    Ray r;
    r.o = w.to_world(rnd(rng, -0.95, 0.95), rnd(rng, -0.95, 0.95), rnd(rng, -0.95, 0.95));
    r.d = random_unit(rng);
    return w.scene.intersect(r, h);
}

std::string where(const Layout& L, const SurfaceHit& h, Vec3 d) {
    char b[300];
    std::snprintf(b, sizeof b, "%s: geom %u prim %u p=(%.9g, %.9g, %.9g) ng=(%.4f, %.4f, %.4f) d=(%.4f, %.4f, %.4f)",
                  L.name, h.geom, h.prim, h.p.x, h.p.y, h.p.z, h.ng.x, h.ng.y, h.ng.z, d.x, d.y, d.z);
    return b;
}

float ulp(float x) { return std::nextafter(std::abs(x), kInf) - std::abs(x); }

}  // namespace

// Spawned rays never re-hit their own primitive at t ~ 0; rays from inside the closed box never escape.
TEST(RayOffsets, NoSelfIntersectionAtAnyScale) {
    for (const Layout& L : kLayouts) {
        const World w = make_world(L, true, 1);
        const Scene& sc = w.scene;
        Rng rng = Rng::for_index(2, Stream::Test, uint64_t(&L - kLayouts));
        int hits = 0, self = 0, escaped = 0, sphere_rays = 0, shard_rays = 0;
        std::string first_failure;
        for (int i = 0; i < 6000; ++i) {
            SurfaceHit h;
            if (!random_hit(w, rng, &h)) {
                ++escaped;  // a ray from inside the closed box must hit something
                if (first_failure.empty()) first_failure = std::string(L.name) + ": a ray from inside the box escaped";
                continue;
            }
            ++hits;
            const bool on_sphere = sc.geoms[h.geom].kind == GeomRef::SphereKind;
            const bool on_box = !on_sphere && sc.geoms[h.geom].index == 0;
            for (int k = 0; k < 8; ++k) {
                Vec3 d = random_unit(rng);
                // Half the rays at grazing angles: the offset is then mostly along the surface.
                if (k % 2) d = normalize(d - h.ng * (dot(d, h.ng) * float(rnd(rng, 0.97, 1.0))));
                const Ray r = spawn_ray(h, d);
                SurfaceHit h2;
                const bool hit2 = sc.intersect(r, &h2);
                const float cos_n = dot(d, h.ng);
                sphere_rays += on_sphere;
                shard_rays += !on_sphere && !on_box;
                if (!hit2) {
                    // Leaving the box through its wall is fine; anything else inside the box must hit.
                    if (!(on_box && cos_n < 0)) {
                        ++escaped;
                        if (first_failure.empty()) first_failure = "escaped: " + where(L, h, d);
                    }
                    continue;
                }
                if (!same_prim(h, h2)) continue;
                bool bad;
                if (on_sphere) {
                    // Outwards: the sphere is never hit again. Inwards: the far side, at 2 r |cos|.
                    const Sphere& S = sc.spheres[sc.geoms[h.geom].index];
                    const double expect = 2.0 * S.radius * std::abs(cos_n);
                    bad = cos_n > 0 || (std::abs(cos_n) > 1e-3f && h2.t < 0.5 * expect);
                } else {
                    bad = true;  // a plane is never hit twice
                }
                if (bad) {
                    ++self;
                    if (first_failure.empty())
                        first_failure = "self-intersection at t=" + std::to_string(h2.t) + ": " + where(L, h, d);
                }
            }
        }
        EXPECT_GT(hits, 5000) << L.name;
        EXPECT_GT(sphere_rays, 2000) << L.name;
        EXPECT_GT(shard_rays, 2000) << L.name;
        EXPECT_EQ(self, 0) << first_failure;
        EXPECT_EQ(escaped, 0) << first_failure;
    }
}

// Scene::occluded between offset surface points agrees with the exact answer: a box with one sphere.
//  - box point to box point (different faces): blocked iff the segment passes through the sphere;
//  - sphere point to box point: open iff the box point is on the outer side of the sphere's tangent
//    plane; a sphere chord (both ends offset inwards) is open;
//  - a box point offset to the outside of its wall, to a point inside: always blocked (the wall);
//    a sphere point offset inwards, to a box point: always blocked (the sphere).
// Cases within rounding of tangency are skipped.
TEST(RayOffsets, OcclusionBetweenSurfacePointsAtAnyScale) {
    for (const Layout& L : kLayouts) {
        World w = make_world(L, false, 3);
        // Keep only the first sphere (centre c, radius r) for exact answers.
        w.scene.spheres.resize(1);
        w.scene.finalize();
        const Scene& sc = w.scene;
        const Sphere S = sc.spheres[0];
        const double cx = S.center.x, cy = S.center.y, cz = S.center.z, r = S.radius;
        // Does the segment a-b (double) pass through the sphere? Returns +1 yes, 0 no, -1 too close to call.
        auto through_sphere = [&](Vec3 a, Vec3 b) {
            const double ax = a.x - cx, ay = a.y - cy, az = a.z - cz;
            const double dx = double(b.x) - a.x, dy = double(b.y) - a.y, dz = double(b.z) - a.z;
            const double dd = dx * dx + dy * dy + dz * dz;
            double t = -(ax * dx + ay * dy + az * dz) / dd;
            t = std::clamp(t, 0.0, 1.0);
            const double px = ax + t * dx, py = ay + t * dy, pz = az + t * dz;
            const double dist = std::sqrt(px * px + py * py + pz * pz);
            // Embree's sphere test rounds at the scale of the centre's coordinates, not of r.
            const double tol = 1e-3 * r + 64.0 * ulp(max_abs_component(S.center));
            if (std::abs(dist - r) < tol) return -1;
            return dist < r ? 1 : 0;
        };
        Rng rng = Rng::for_index(4, Stream::Test, uint64_t(&L - kLayouts));
        std::vector<SurfaceHit> box_pts, sph_pts;
        while (box_pts.size() < 400 || sph_pts.size() < 400) {
            SurfaceHit h;
            if (!random_hit(w, rng, &h)) continue;
            if (sc.geoms[h.geom].kind == GeomRef::SphereKind) {
                if (sph_pts.size() < 400) sph_pts.push_back(h);
            } else if (box_pts.size() < 400) {
                box_pts.push_back(h);
            }
        }
        int wrong = 0, checked = 0;
        std::string first;
        auto check = [&](bool got, bool want, const std::string& what) {
            ++checked;
            if (got != want && ++wrong == 1) first = std::string(L.name) + ": " + what + (want ? " not blocked" : " blocked");
        };
        for (size_t i = 0; i < box_pts.size(); ++i) {
            const SurfaceHit& a = box_pts[i];
            // Box to box.
            const SurfaceHit& b = box_pts[(i * 7 + 3) % box_pts.size()];
            if (dot(a.ng, b.ng) < 0.5f) {  // different faces (same face: the segment lies in the wall)
                const int thr = through_sphere(a.p, b.p);
                if (thr >= 0) {
                    const Vec3 d = b.p - a.p;
                    const bool got = sc.occluded(offset_ray_origin(a.p, a.ng, d, a.magnitude), offset_ray_origin(b.p, b.ng, -d, b.magnitude));
                    check(got, thr == 1, "box-box " + where(L, a, normalize(d)) + " to " + where(L, b, normalize(d)));
                }
            }
            // Through its own wall: from just outside the wall to the box centre region.
            const Vec3 q = w.to_world(rnd(rng, -0.2, 0.2), rnd(rng, -0.2, 0.2), 0.95);
            if (through_sphere(a.p, q) == 0) {
                const Vec3 d = q - a.p;
                const bool got = sc.occluded(offset_ray_origin(a.p, a.ng, -d, a.magnitude), q);
                check(got, true, "outside-in " + where(L, a, normalize(d)));
            }
        }
        for (size_t i = 0; i < sph_pts.size(); ++i) {
            const SurfaceHit& a = sph_pts[i];
            const SurfaceHit& b = box_pts[(i * 13 + 5) % box_pts.size()];
            const Vec3 d = b.p - a.p;
            const double c = dot(normalize(d), a.ng);
            if (std::abs(c) > 1e-3) {
                const bool got = sc.occluded(offset_ray_origin(a.p, a.ng, d, a.magnitude), offset_ray_origin(b.p, b.ng, -d, b.magnitude));
                check(got, c < 0, "sphere-box " + where(L, a, normalize(d)));
            }
            // From inside the sphere (offset inwards) to a box point: the sphere's own surface blocks.
            if (std::abs(c) > 1e-3 && c > 0) {
                const bool got = sc.occluded(offset_ray_origin(a.p, a.ng, -a.ng, a.magnitude), offset_ray_origin(b.p, b.ng, -d, b.magnitude));
                check(got, true, "sphere-inside-out " + where(L, a, normalize(d)));
            }
            // Chord: both ends offset inwards.
            const SurfaceHit& e = sph_pts[(i * 11 + 1) % sph_pts.size()];
            const Vec3 ch = e.p - a.p;
            if (length(ch) > 1e-2f * S.radius && dot(normalize(ch), a.ng) < -1e-3f) {
                const bool got = sc.occluded(offset_ray_origin(a.p, a.ng, ch, a.magnitude), offset_ray_origin(e.p, e.ng, -ch, e.magnitude));
                check(got, false, "chord " + where(L, a, normalize(ch)));
            }
        }
        EXPECT_GT(checked, 1200) << L.name;
        EXPECT_EQ(wrong, 0) << wrong << " of " << checked << " wrong; first: " << first;
    }
}

// The offset is small: at most 512 ULPs of the point's largest coordinate plus 1e-4 of the scene's
// size. A fixed absolute offset fails this at small scales (it is a sizeable fraction of a
// millimetre-sized scene), and then NEE and continuation rays start visibly off the surface.
TEST(RayOffsets, OffsetIsRelativeToTheScene) {
    for (const Layout& L : kLayouts) {
        const World w = make_world(L, true, 5);
        const Scene& sc = w.scene;
        const float size = length(sc.bounds_max - sc.bounds_min);
        Rng rng = Rng::for_index(6, Stream::Test, uint64_t(&L - kLayouts));
        float worst = 0;
        std::string worst_at;
        for (int i = 0; i < 2000; ++i) {
            SurfaceHit h;
            if (!random_hit(w, rng, &h)) continue;
            const Vec3 d = random_unit(rng);
            const Vec3 o = spawn_ray(h, d).o;
            ASSERT_TRUE(is_finite(o));
            const float moved = length(o - h.p);
            const float allowed = 512 * ulp(max_abs_component(h.p)) + 1e-4f * size;
            if (moved / allowed > worst) {
                worst = moved / allowed;
                worst_at = where(L, h, d) + " moved " + std::to_string(moved);
            }
        }
        EXPECT_LE(worst, 1.0f) << worst_at;
    }
}
