// Chi-square tests of sample_light's directions against light_pdf (tests/support/chi2.h): the
// density of a direction w is the sum of light_pdf over every light point that the ray (ref, w)
// reaches (ray casting here is in double, independent of lights.cpp). Point lights are discrete
// samples and excluded, as chi2.h prescribes. Sidak-corrected over the kLightChi2Tests tests here.
//
// Spheres seen from outside are tested through a "cap zoom" (see test_warps_chi2.cpp): a fixed
// bijection that stretches the cap around +z containing the subtended cone onto the whole sphere,
// so that small cones fill the grid and the cone's rim lies on a cell edge. Those spheres sit at the
// origin with the reference point on the -z axis: positions near the origin have tiny float ULPs, so
// the sampled directions are exact enough for a cone of 1 - cos = 2.5e-6.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "libcommon/lights.h"
#include "libcommon/scene.h"
#include "support/chi2.h"

namespace iris {
namespace {

constexpr int kLightChi2Tests = 10;

Mesh quad_mesh(Vec3 c, Vec3 e1, Vec3 e2) {
    Mesh m;
    m.positions = {c, c + e1, c + e1 + e2, c + e2};
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

void add_mesh_light(Scene& s, Mesh m, RGB radiance) {
    m.light = int32_t(s.lights.size());
    s.meshes.push_back(std::move(m));
    Light l;
    l.type = LightType::AreaMesh;
    l.shape = uint32_t(s.meshes.size() - 1);
    l.radiance = radiance;
    s.lights.push_back(l);
}

void add_sphere_light(Scene& s, Vec3 c, float r, RGB radiance, bool flip = false) {
    Sphere sp;
    sp.center = c;
    sp.radius = r;
    sp.flip_normals = flip;
    sp.light = int32_t(s.lights.size());
    s.spheres.push_back(sp);
    Light l;
    l.type = LightType::AreaSphere;
    l.shape = uint32_t(s.spheres.size() - 1);
    l.radiance = radiance;
    s.lights.push_back(l);
}

struct Dir {
    double x, y, z;
};

// Density per steradian (including selection) of sample_light producing direction w from ref.
double direction_pdf(const Scene& scene, Vec3 ref, Dir w) {
    const double o[3] = {ref.x, ref.y, ref.z}, d[3] = {w.x, w.y, w.z};
    Vec3 wf(float(w.x), float(w.y), float(w.z));
    auto at = [&](double t) { return Vec3(float(o[0] + t * d[0]), float(o[1] + t * d[1]), float(o[2] + t * d[2])); };
    double sum = 0;
    for (uint32_t li = 0; li < scene.lights.size(); ++li) {
        const Light& l = scene.lights[li];
        if (l.type == LightType::AreaMesh) {
            const Mesh& m = scene.meshes[l.shape];
            for (uint32_t t = 0; t < m.triangle_count(); ++t) {
                // Moeller-Trumbore in double.
                Vec3 p0 = m.positions[m.indices[3 * t]], p1 = m.positions[m.indices[3 * t + 1]],
                     p2 = m.positions[m.indices[3 * t + 2]];
                double e1[3] = {double(p1.x) - p0.x, double(p1.y) - p0.y, double(p1.z) - p0.z};
                double e2[3] = {double(p2.x) - p0.x, double(p2.y) - p0.y, double(p2.z) - p0.z};
                double pv[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
                double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
                if (std::abs(det) < 1e-300) continue;
                double tv[3] = {o[0] - p0.x, o[1] - p0.y, o[2] - p0.z};
                double u = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) / det;
                double qv[3] = {tv[1] * e1[2] - tv[2] * e1[1], tv[2] * e1[0] - tv[0] * e1[2], tv[0] * e1[1] - tv[1] * e1[0]};
                double v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det;
                double th = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
                if (u < 0 || v < 0 || u + v > 1 || th <= 0) continue;
                Vec3 n = normalize(cross(p1 - p0, p2 - p0));
                if (m.flip_normals) n = -n;
                sum += light_pdf(scene, li, t, ref, at(th), n, wf);
            }
        } else if (l.type == LightType::AreaSphere) {
            const Sphere& sp = scene.spheres[l.shape];
            double oc[3] = {o[0] - sp.center.x, o[1] - sp.center.y, o[2] - sp.center.z};
            double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
            double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - double(sp.radius) * sp.radius;
            double a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            double disc = b * b - a * c;
            if (disc < 0) continue;
            for (double t : {(-b - std::sqrt(disc)) / a, (-b + std::sqrt(disc)) / a}) {
                if (t <= 0) continue;
                Vec3 p = at(t);
                Vec3 n = normalize(p - sp.center);
                if (sp.flip_normals) n = -n;
                sum += light_pdf(scene, li, 0, ref, p, n, wf);
            }
        } else if (l.type == LightType::Constant || l.type == LightType::Envmap) {
            sum += light_pdf(scene, li, 0, ref, Vec3(0), Vec3(0), wf);
        }
        // Point, spot and directional lights: deltas, excluded from the continuous density.
    }
    return sum;
}

test::DirSample light_direction(const Scene& scene, Vec3 ref, Rng& rng) {
    LightSample s;
    float u_sel = rng.next_float();
    Vec2 u{rng.next_float(), rng.next_float()};
    if (!sample_light(scene, ref, u_sel, u, &s)) return {};
    return {s.wi, true, s.delta};
}

// The summary line (statistic, dof, p-value) is printed for every test, the cell table on failure.
void report(const test::Chi2Result& r) {
    std::printf("    %s", r.log.substr(0, r.log.find('\n') + 1).c_str());
    EXPECT_TRUE(r.passed) << r.log;
}

test::Chi2Options options() {
    test::Chi2Options o;
    o.test_count = kLightChi2Tests;
    o.samples = 1000000;
    return o;
}

// Zoomed directions are a function of u alone (the cone warp, stretched), so zoomed tests of different
// spheres take different seeds to stay independent.
test::Chi2Options zoom_options(uint64_t seed) {
    test::Chi2Options o = options();
    o.seed = seed;
    return o;
}

// How a test integrates the expected counts of its cells.
enum class Quadrature {
    // chi2.h's adaptive rule: for densities that are smooth inside every cell (no outline crosses
    // a cell, or the outline lies on cell edges).
    Adaptive,
    // A fixed 80 x 80 midpoint rule per cell, for emitter outlines that cut through cells. The
    // adaptive rule is unreliable there: a piecewise-constant density can give the same count of
    // inside points at two successive levels and stop refining with a large error (seen with a
    // sphere's outline running along a row of cells). The fixed rule's error is bounded by the
    // outline's share of sub-cells (well under the sampling noise at 1e6 samples).
    FixedFine,
};

// Unzoomed test on the whole sphere of directions.
void run_plain(const Scene& scene, Vec3 ref, Quadrature quad) {
    test::Chi2Options o = options();
    if (quad == Quadrature::FixedFine) {
        o.quadrature = 40;
        o.quad_max_depth = 0;  // the 2 x 2 split of the first level, then stop: 80 x 80 points
    }
    auto r = test::chi2_test_sphere([&](Rng& rng) { return light_direction(scene, ref, rng); },
                                    [&](Vec3 w) { return direction_pdf(scene, ref, {w.x, w.y, w.z}); }, o);
    report(r);
}

// Zoomed test for a scene whose lights all lie inside the cone 1 - cos(theta) <= omc around +z.
void run_zoomed(const Scene& scene, Vec3 ref, double omc, uint64_t seed) {
    const double cap = omc / 0.8;  // the rim maps to z = -0.6, a cell edge
    long long outside = 0;
    auto r = test::chi2_test_sphere(
        [&](Rng& rng) {
            test::DirSample s = light_direction(scene, ref, rng);
            if (!s.valid) return s;
            double t = double(one_minus_cos_theta(s.w));
            if (t > cap) {
                ++outside;
                return test::DirSample{};
            }
            double tz = 2.0 * t / cap, sn = std::sqrt(std::max(0.0, tz * (2.0 - tz)));
            double phi = std::atan2(double(s.w.y), double(s.w.x));
            s.w = Vec3(float(sn * std::cos(phi)), float(sn * std::sin(phi)), float(1.0 - tz));
            return s;
        },
        [&](Vec3 wz) {
            double t = (1.0 - double(wz.z)) * cap / 2.0;
            double sn = std::sqrt(std::max(0.0, t * (2.0 - t)));
            double phi = std::atan2(double(wz.y), double(wz.x));
            return direction_pdf(scene, ref, {sn * std::cos(phi), sn * std::sin(phi), 1.0 - t}) * cap / 2.0;
        },
        zoom_options(seed));
    EXPECT_EQ(outside, 0) << "directions outside the subtended cone";
    report(r);
}

double sphere_omc(double r, double d) {
    double s2 = r * r / (d * d);
    return s2 / (1.0 + std::sqrt(1.0 - s2));
}

TEST(LightChi2, QuadMeshLight) {
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -0.5f, 1}, {0, 2, 0}, {2.5f, 0, 0}), RGB(1, 1, 1));  // normal -z
    lights_prepare(s);
    run_plain(s, Vec3(0.2f, 0.1f, 0.3f), Quadrature::FixedFine);
}

TEST(LightChi2, TessellatedQuadNearAndFarTriangles) {
    // A 4 x 4 quad of 8 x 8 cells seen from 0.15 above one corner: the triangles nearby subtend more
    // than kSolidAngleSampling (0.1 sr) and are sampled in solid angle, the far ones by area, in one light.
    Scene s;
    Mesh m;
    for (int j = 0; j <= 8; ++j)
        for (int i = 0; i <= 8; ++i) m.positions.push_back(Vec3(-2.0f + 0.5f * i, -2.0f + 0.5f * j, 0.0f));
    for (uint32_t j = 0; j < 8; ++j)
        for (uint32_t i = 0; i < 8; ++i) {
            const uint32_t a = j * 9 + i;
            m.indices.insert(m.indices.end(), {a, a + 1, a + 10, a, a + 10, a + 9});  // normal +z
        }
    add_mesh_light(s, std::move(m), RGB(1, 1, 1));
    lights_prepare(s);
    run_plain(s, Vec3(-1.3f, -1.4f, 0.15f), Quadrature::FixedFine);
}

TEST(LightChi2, SphereFromOutsideLargeAngle) {
    Scene s;
    add_sphere_light(s, {0, 0, 0}, 1.0f, RGB(1, 1, 1));
    lights_prepare(s);
    run_zoomed(s, Vec3(0, 0, -1.5f), sphere_omc(1.0, 1.5), 101);
}

TEST(LightChi2, SphereFromOutsideTinyAngle) {
    // The veach_mi small light: r = 0.0333 seen from 15 units.
    Scene s;
    add_sphere_light(s, {0, 0, 0}, 0.0333f, RGB(100, 100, 100));
    lights_prepare(s);
    run_zoomed(s, Vec3(0, 0, -15.0f), sphere_omc(0.0333f, 15.0), 102);
}

TEST(LightChi2, SphereFromInside) {
    Scene s;
    add_sphere_light(s, {0, 0, 0}, 1.0f, RGB(1, 1, 1), /*flip=*/true);
    lights_prepare(s);
    run_plain(s, Vec3(0.3f, 0.2f, -0.4f), Quadrature::Adaptive);  // smooth density d^2 / (A cos)
}

TEST(LightChi2, TwoLightsMixture) {
    // A quad and a sphere of different powers, so the selection probabilities differ (about
    // 0.28 / 0.72). The sphere lies sideways (towards -y): an outline around a pole would run along a
    // row of cells, the worst case for any quadrature of the expected counts.
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -1, 1}, {0, 2, 0}, {2, 0, 0}), RGB(1, 1, 1));  // facing -z
    add_sphere_light(s, {0.3f, -2, -0.2f}, 1.0f, RGB(0.8f, 0.8f, 0.8f));
    lights_prepare(s);
    EXPECT_GT(std::abs(light_selection_pmf(s, 0) - light_selection_pmf(s, 1)), 0.2f);
    run_plain(s, Vec3(0.1f, -0.2f, 0.1f), Quadrature::FixedFine);
}

TEST(LightChi2, TwoSpheresMixtureOnCellEdges) {
    // Two spheres on the z axis, sized so that their outlines are the circles z = -0.6 and z = 0.8,
    // cell edges of the grid: every cell then has a constant density and the expected counts are
    // exact, so this mixture is checked at full sensitivity. cos(theta_max) = sqrt(1 - r^2/d^2).
    Scene s;
    add_sphere_light(s, {0, 0, -1}, 0.8f, RGB(1, 1, 1));   // cos(theta_max) = 0.6
    add_sphere_light(s, {0, 0, 1}, 0.6f, RGB(4, 4, 4));    // cos(theta_max) = 0.8
    lights_prepare(s);
    EXPECT_GT(std::abs(light_selection_pmf(s, 0) - light_selection_pmf(s, 1)), 0.2f);
    run_plain(s, Vec3(0, 0, 0), Quadrature::Adaptive);
}

TEST(LightChi2, MixtureWithEnvironmentAndPointLight) {
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -1, 1}, {0, 2, 0}, {2, 0, 0}), RGB(2, 2, 2));
    Light pt;
    pt.type = LightType::Point;
    pt.position = Vec3(0, 0, -1);
    pt.radiance = RGB(3, 3, 3);
    s.lights.push_back(pt);
    Light env;
    env.type = LightType::Constant;
    env.radiance = RGB(0.05f, 0.05f, 0.05f);
    s.lights.push_back(env);
    s.bounds_min = Vec3(-2, -2, -2);
    s.bounds_max = Vec3(2, 2, 2);
    lights_prepare(s);
    for (uint32_t i = 0; i < 3; ++i) EXPECT_GT(light_selection_pmf(s, i), 0.1f) << i;
    run_plain(s, Vec3(0.1f, -0.2f, 0.1f), Quadrature::FixedFine);
}

// A small latlong map with a bright spot, a black row and a black column, structure at every scale the
// grid sees (12 x 6 texels: texel edges do not lie on cell edges, hence the fixed fine quadrature).
std::shared_ptr<const EnvMap> test_envmap(const Transform& to_world) {
    const int w = 12, h = 6;
    std::vector<RGB> t(size_t(w * h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            RGB v(0.2f + 0.1f * float(x), 0.5f, 0.1f + 0.3f * float(y));  // a gradient
            if (y == 1) v = RGB(0);                                       // a black row
            if (x == 7) v = RGB(0);                                       // a black column
            if (x == 3 && y == 2) v = RGB(40, 30, 20);                    // the "sun"
            t[size_t(y * w + x)] = v;
        }
    return make_envmap(w, h, std::move(t), to_world);
}

TEST(LightChi2, Envmap) {
    Scene s;
    Light env;
    env.type = LightType::Envmap;
    env.envmap = test_envmap(Transform());
    s.lights.push_back(env);
    s.bounds_min = Vec3(-1);
    s.bounds_max = Vec3(1);
    lights_prepare(s);
    run_plain(s, Vec3(0.1f, 0.2f, -0.3f), Quadrature::FixedFine);
}

TEST(LightChi2, RotatedEnvmapWithAreaLight) {
    // toWorld tilts the map's +y up by 60 degrees, mixed with an area light chosen by power. (Not by 90:
    // the map's pole, where the density per steradian grows as 1 / sin(theta), would then sit on the
    // grid's pole, where chi2.h's fixed quadrature cannot integrate it.)
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -1, 1}, {0, 2, 0}, {2, 0, 0}), RGB(20, 20, 20));
    Light env;
    env.type = LightType::Envmap;
    env.envmap = test_envmap(Transform::rotate(Vec3(1, 0, 0), 60) * Transform::rotate(Vec3(0, 1, 0), 30));
    s.lights.push_back(env);
    s.bounds_min = Vec3(-2);
    s.bounds_max = Vec3(2);
    lights_prepare(s);
    for (uint32_t i = 0; i < 2; ++i) EXPECT_GT(light_selection_pmf(s, i), 0.05f) << i;
    run_plain(s, Vec3(0.1f, -0.2f, 0.1f), Quadrature::FixedFine);
}

}  // namespace
}  // namespace iris
