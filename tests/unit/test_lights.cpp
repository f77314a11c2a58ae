// Exact checks of the lights: power formulas, selection in proportion to power, light_pdf equal to
// the pdf sample_light reports (the MIS contract), sampled points on their emitters and visible,
// accuracy for tiny distant spheres, and no NaN/Inf at the degenerate configurations.
// Scenes are built by hand and prepared with lights_prepare() (Scene::finalize would also build BSDFs
// and the BVH, which these tests do not need).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "libcommon/lights.h"
#include "libcommon/rng.h"
#include "libcommon/scene.h"

namespace iris {
namespace {

constexpr float kOneMinusEps = 0x1.fffffep-1f;

// A parallelogram light: corner c, edges e1, e2; geometric normal along cross(e1, e2).
Mesh quad_mesh(Vec3 c, Vec3 e1, Vec3 e2) {
    Mesh m;
    m.name = "quad";
    m.positions = {c, c + e1, c + e1 + e2, c + e2};
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

uint32_t add_mesh_light(Scene& s, Mesh m, RGB radiance) {
    m.light = int32_t(s.lights.size());
    s.meshes.push_back(std::move(m));
    Light l;
    l.type = LightType::AreaMesh;
    l.shape = uint32_t(s.meshes.size() - 1);
    l.radiance = radiance;
    s.lights.push_back(l);
    return uint32_t(s.lights.size() - 1);
}

uint32_t add_sphere_light(Scene& s, Vec3 c, float r, RGB radiance, bool flip = false) {
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
    return uint32_t(s.lights.size() - 1);
}

uint32_t add_point_light(Scene& s, Vec3 p, RGB intensity) {
    Light l;
    l.type = LightType::Point;
    l.position = p;
    l.radiance = intensity;
    s.lights.push_back(l);
    return uint32_t(s.lights.size() - 1);
}

uint32_t add_constant_light(Scene& s, RGB radiance) {
    Light l;
    l.type = LightType::Constant;
    l.radiance = radiance;
    s.lights.push_back(l);
    return uint32_t(s.lights.size() - 1);
}

// Nearest hit of the ray (o, w) with a sphere, in double; nullopt on a miss.
std::optional<double> ray_sphere(Vec3 o, Vec3 w, Vec3 c, float r) {
    double ox = double(o.x) - c.x, oy = double(o.y) - c.y, oz = double(o.z) - c.z;
    double wx = w.x, wy = w.y, wz = w.z;
    double a = wx * wx + wy * wy + wz * wz, b = ox * wx + oy * wy + oz * wz;
    double cc = ox * ox + oy * oy + oz * oz - double(r) * r;
    double disc = b * b - a * cc;
    if (disc < 0) return std::nullopt;
    double sq = std::sqrt(disc);
    double t0 = (-b - sq) / a, t1 = (-b + sq) / a;
    if (t0 > 0) return t0;
    if (t1 > 0) return t1;
    return std::nullopt;
}

void expect_finite(const LightSample& s) {
    EXPECT_TRUE(is_finite(s.p));
    EXPECT_TRUE(is_finite(s.n));
    EXPECT_TRUE(is_finite(s.wi));
    EXPECT_FALSE(std::isnan(s.dist));
    EXPECT_TRUE(is_finite(s.radiance));
    EXPECT_TRUE(std::isfinite(s.pdf));
    EXPECT_GE(s.pdf, 0.0f);
}

// Over a grid of u including the edges: every successful sample is finite, has a positive pdf, and
// light_pdf for the sampled point returns exactly that pdf. Returns the number of successes.
int check_pdf_consistency(const Scene& scene, Vec3 ref, int n = 40) {
    int ok = 0;
    std::vector<float> us;
    for (int i = 0; i < n; ++i) us.push_back(float(i) / n);
    us.push_back(kOneMinusEps);
    for (float u_sel : {0.0f, 0.3f, 0.7f, kOneMinusEps})
        for (float a : us)
            for (float b : us) {
                LightSample s;
                if (!sample_light(scene, ref, u_sel, {a, b}, &s)) {
                    EXPECT_EQ(s.pdf, 0.0f);
                    continue;
                }
                ++ok;
                expect_finite(s);
                EXPECT_GT(s.pdf, 0.0f);
                EXPECT_NEAR(length(s.wi), 1.0f, 1e-5f);
                float pdf = light_pdf(scene, s.light, s.prim, ref, s.p, s.n, s.wi);
                EXPECT_EQ(pdf, s.pdf) << "light " << s.light << " u_sel " << u_sel << " u " << a << "," << b;
            }
    return ok;
}

TEST(Lights, PowerFormulas) {
    Scene s;
    const RGB L(1, 2, 3);
    uint32_t q = add_mesh_light(s, quad_mesh({0, 0, 0}, {2, 0, 0}, {0, 3, 0}), L);
    uint32_t sp = add_sphere_light(s, {5, 0, 0}, 0.5f, L);
    uint32_t pt = add_point_light(s, {0, 0, 2}, L);
    uint32_t env = add_constant_light(s, L);
    s.bounds_min = Vec3(-1, -2, -3);
    s.bounds_max = Vec3(1, 2, 3);
    lights_prepare(s);
    auto near = [](RGB a, RGB b) {
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-5 * std::abs(b[c]));
    };
    near(light_power(s, s.lights[q]), L * float(M_PI * 6.0));                    // pi A L, A = 6
    near(light_power(s, s.lights[sp]), L * float(M_PI * 4 * M_PI * 0.25));       // pi 4 pi r^2 L
    near(light_power(s, s.lights[pt]), L * float(4 * M_PI));                     // 4 pi I
    near(light_power(s, s.lights[env]), L * float(M_PI * 14.0 * 4 * M_PI));      // pi R^2 4 pi L, R^2 = 1+4+9
    EXPECT_NEAR(s.lights[q].area, 6.0f, 1e-6f);
    EXPECT_NEAR(s.lights[sp].area, float(4 * M_PI * 0.25), 1e-6f);
    EXPECT_EQ(s.environment_light, int(env));

    // Unset bounds: the environment's radius comes from the geometry (quad and sphere here).
    s.bounds_min = Vec3(kInf);
    s.bounds_max = Vec3(-kInf);
    // Geometry spans x in [0, 5.5], y in [-0.5, 3], z in [-0.5, 0.5].
    double r2 = (5.5 * 5.5 + 3.5 * 3.5 + 1.0) / 4.0;
    near(light_power(s, s.lights[env]), L * float(M_PI * r2 * 4 * M_PI));
}

TEST(Lights, SelectionProportionalToPower) {
    Scene s;
    uint32_t q = add_mesh_light(s, quad_mesh({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}), RGB(1, 1, 1));  // P = 4 pi
    uint32_t sp = add_sphere_light(s, {0, 0, 3}, 0.5f, RGB(4, 2, 1));
    uint32_t dark = add_sphere_light(s, {3, 0, 3}, 0.5f, RGB(0, 0, 0));
    s.lights[sp].sampling_weight = 1.5f;
    lights_prepare(s);
    double wq = luminance(RGB(1, 1, 1)) * 4 * M_PI;
    double ws = luminance(RGB(4, 2, 1)) * M_PI * 4 * M_PI * 0.25 * 1.5;
    EXPECT_NEAR(light_selection_pmf(s, q), wq / (wq + ws), 1e-6);
    EXPECT_NEAR(light_selection_pmf(s, sp), ws / (wq + ws), 1e-6);
    EXPECT_EQ(light_selection_pmf(s, dark), 0.0f);
    EXPECT_EQ(light_selection_pmf(s, 99), 0.0f);

    // Frequencies of sample_light's choices, from a point that sees both lights fully.
    Vec3 ref(0.2f, 0.1f, 1.0f);
    Rng rng(11, 12);
    const int n = 200000;
    int count[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i) {
        LightSample ls;
        ASSERT_TRUE(sample_light(s, ref, rng.next_float(), {rng.next_float(), rng.next_float()}, &ls));
        ++count[ls.light];
    }
    double p = light_selection_pmf(s, q);
    EXPECT_NEAR(count[q] / double(n), p, 5 * std::sqrt(p * (1 - p) / n));
    EXPECT_EQ(count[dark], 0);
}

TEST(Lights, MeshPdfMatchesSample) {
    Scene s;
    // A quad facing +z plus a triangle of a different size facing -x, in one mesh, and a degenerate
    // (zero-area) triangle between them that must never be chosen.
    Mesh m = quad_mesh({-1, -1, 0}, {2, 0, 0}, {0, 2, 0});
    m.positions.push_back({2, 0, 1});
    m.positions.push_back({2, 1, 1});
    m.positions.push_back({2, 0, 3});
    m.indices.insert(m.indices.end(), {4, 6, 5});    // normal -x
    m.indices.insert(m.indices.end(), {0, 0, 2});    // degenerate
    m.indices.insert(m.indices.end(), {0, 2, 2});    // degenerate
    add_mesh_light(s, m, RGB(2, 2, 2));
    lights_prepare(s);
    const Light& l = s.lights[0];
    EXPECT_NEAR(l.area, 4.0f + 1.0f, 1e-6f);
    EXPECT_EQ(l.triangles.pmf(3), 0.0f);
    EXPECT_EQ(l.triangles.pmf(4), 0.0f);
    EXPECT_NEAR(l.triangles.pmf(2), 0.2f, 1e-7f);
    // From a point that sees the quad's front and the triangle's front.
    int ok = check_pdf_consistency(s, Vec3(0.3f, 0.2f, 1.5f));
    EXPECT_GT(ok, 1000);

    // From far away (every triangle under kSolidAngleSampling: area sampling) the sampled points lie on the mesh,
    // with the normal of their triangle, and the pdf is the area density converted to solid angle.
    Rng rng(13, 14);
    Vec3 ref(0.3f, 0.2f, 40.0f);
    EXPECT_GT(check_pdf_consistency(s, ref), 1000);
    for (int i = 0; i < 10000; ++i) {
        LightSample ls;
        if (!sample_light(s, ref, rng.next_float(), {rng.next_float(), rng.next_float()}, &ls)) continue;
        bool on_quad = std::abs(ls.p.z) < 1e-6f && std::abs(ls.p.x) <= 1 && std::abs(ls.p.y) <= 1;
        bool on_tri = std::abs(ls.p.x - 2) < 1e-6f;
        ASSERT_TRUE(on_quad || on_tri) << ls.p.x << " " << ls.p.y << " " << ls.p.z;
        Vec3 n_expected = on_quad ? Vec3(0, 0, 1) : Vec3(-1, 0, 0);
        EXPECT_NEAR(dot(ls.n, n_expected), 1.0f, 1e-6f);
        Vec3 d = ls.p - ref;
        double expected = double(length_sq(d)) / (5.0 * double(dot(ls.n, -normalize(d))));
        EXPECT_NEAR(ls.pdf, expected, 1e-5 * expected);
        EXPECT_NEAR(ls.dist, length(d), 1e-5f);
    }
}

// Solid angle of the spherical triangle (a, b, c) by Girard's theorem (the angle excess), in double: a
// different formula from the renderer's (Van Oosterom and Strackee).
double girard_solid_angle(Vec3 ref, Vec3 p0, Vec3 p1, Vec3 p2) {
    auto unit = [&](Vec3 p) {
        double x = double(p.x) - ref.x, y = double(p.y) - ref.y, z = double(p.z) - ref.z, l = std::sqrt(x * x + y * y + z * z);
        return std::array<double, 3>{x / l, y / l, z / l};
    };
    auto cross3 = [](std::array<double, 3> a, std::array<double, 3> b) {
        return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    };
    // The angle at vertex a between the arcs to b and to c.
    auto corner = [&](std::array<double, 3> a, std::array<double, 3> b, std::array<double, 3> c) {
        auto n1 = cross3(a, b), n2 = cross3(a, c);
        double d = n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2];
        double l = std::sqrt((n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]) * (n2[0] * n2[0] + n2[1] * n2[1] + n2[2] * n2[2]));
        return std::acos(std::clamp(d / l, -1.0, 1.0));
    };
    auto a = unit(p0), b = unit(p1), c = unit(p2);
    return corner(a, b, c) + corner(b, c, a) + corner(c, a, b) - kPi;
}

TEST(Lights, NearTrianglesAreSampledInSolidAngle) {
    // Near a quad light (both triangles above kSolidAngleSampling) the points lie on the quad, uniformly
    // in solid angle: pdf = (the triangle's share of the area) / (its solid angle), per triangle.
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}), RGB(2, 2, 2));  // normal +z
    lights_prepare(s);
    const Mesh& m = s.meshes[0];
    Rng rng(21, 22);
    for (Vec3 ref : {Vec3(0.3f, 0.2f, 0.5f), Vec3(0.1f, -0.1f, 0.05f), Vec3(1.5f, 0.2f, 0.5f)}) {
        EXPECT_GT(check_pdf_consistency(s, ref), 1000);
        double omega[2];
        for (uint32_t t = 0; t < 2; ++t) {
            omega[t] = girard_solid_angle(ref, m.positions[m.indices[3 * t]], m.positions[m.indices[3 * t + 1]],
                                          m.positions[m.indices[3 * t + 2]]);
            ASSERT_GT(omega[t], 1.01 * kSolidAngleSampling) << "the test wants both triangles sampled in solid angle";
        }
        int counts[2] = {0, 0};
        for (int i = 0; i < 20000; ++i) {
            LightSample ls;
            ASSERT_TRUE(sample_light(s, ref, rng.next_float(), {rng.next_float(), rng.next_float()}, &ls));
            ASSERT_LT(ls.prim, 2u);
            ++counts[ls.prim];
            EXPECT_NEAR(ls.p.z, 0.0f, 1e-6f);
            EXPECT_LE(std::abs(ls.p.x), 1.0f + 1e-5f);
            EXPECT_LE(std::abs(ls.p.y), 1.0f + 1e-5f);
            EXPECT_NEAR(dot(ls.wi, normalize(ls.p - ref)), 1.0f, 1e-5f);
            EXPECT_NEAR(ls.dist, length(ls.p - ref), 1e-5f * ls.dist);
            EXPECT_NEAR(ls.pdf, 0.5 / omega[ls.prim], 1e-5 * ls.pdf) << "triangle " << ls.prim;
        }
        EXPECT_GT(counts[0], 9000);  // each triangle is half the area
        EXPECT_GT(counts[1], 9000);
    }
}

TEST(Lights, SolidAngleDecidesTheSampler) {
    // One triangle, reference points scattered in front of it: every point whose triangle subtends more
    // than kSolidAngleSampling (and less than 6.2 sr) is sampled in solid angle, pdf = 1 / Omega; every
    // point under it by area, pdf = d^2 / (A cos). Catches a far test that sends near triangles to area
    // sampling (which would stay unbiased, so no statistical test would notice).
    Scene s;
    Mesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0.2f, 0.8f, 0}};  // area 0.4, normal +z
    m.indices = {0, 1, 2};
    add_mesh_light(s, m, RGB(1, 1, 1));
    lights_prepare(s);
    Rng rng(31, 32);
    int spherical = 0, by_area = 0;
    auto check = [&](Vec3 ref) {
        const double omega = girard_solid_angle(ref, m.positions[0], m.positions[1], m.positions[2]);
        LightSample ls;
        ASSERT_TRUE(sample_light(s, ref, 0.5f, {rng.next_float(), rng.next_float()}, &ls));
        if (omega > 1.01 * kSolidAngleSampling && omega < 6.1) {
            ++spherical;
            EXPECT_NEAR(ls.pdf, 1.0 / omega, 1e-4 * ls.pdf) << ref.x << " " << ref.y << " " << ref.z;
        } else if (omega < 0.99 * kSolidAngleSampling || omega > 6.3) {
            ++by_area;
            Vec3 d = ls.p - ref;
            double expected = double(length_sq(d)) / (0.4 * double(dot(ls.n, -normalize(d))));
            EXPECT_NEAR(ls.pdf, expected, 1e-4 * expected) << ref.x << " " << ref.y << " " << ref.z;
        }
    };
    for (int i = 0; i < 4000; ++i)
        check(Vec3(4 * rng.next_float() - 1.5f, 4 * rng.next_float() - 1.5f, 2 * rng.next_float() * rng.next_float() + 1e-3f));
    // Almost on the triangle, over its interior: more than 6.2 sr, area sampling again.
    check(Vec3(0.4f, 0.3f, 1e-4f));
    EXPECT_GT(spherical, 500);
    EXPECT_GT(by_area, 500);
}

TEST(Lights, MeshEmitsOnNormalSideOnly) {
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}), RGB(1, 1, 1));  // normal +z
    lights_prepare(s);
    const Light& l = s.lights[0];
    EXPECT_EQ(light_emitted(l, {0, 0, 1}, normalize(Vec3(0.1f, 0, 1))).r, 1.0f);
    EXPECT_EQ(light_emitted(l, {0, 0, 1}, normalize(Vec3(0.1f, 0, -1))).r, 0.0f);
    Vec3 below(0.1f, 0.2f, -1.0f);
    EXPECT_EQ(check_pdf_consistency(s, below, 10), 0);
    EXPECT_EQ(light_pdf(s, 0, 0, below, Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 1)), 0.0f);
    // Flipped: emits downwards.
    s.meshes[0].flip_normals = true;
    lights_prepare(s);
    EXPECT_GT(check_pdf_consistency(s, below, 10), 0);
    EXPECT_EQ(check_pdf_consistency(s, Vec3(0.1f, 0.2f, 1.0f), 10), 0);
    LightSample ls;
    ASSERT_TRUE(sample_light(s, below, 0.5f, {0.3f, 0.6f}, &ls));
    EXPECT_NEAR(ls.n.z, -1.0f, 1e-6f);
}

TEST(Lights, MeshNoNanAtDegenerateReferencePoints) {
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}), RGB(1, 1, 1));
    lights_prepare(s);
    // On the light's plane (outside and inside the quad, and on a vertex), very far, very close.
    for (Vec3 ref : {Vec3(3, 0, 0), Vec3(0, 0, 0), Vec3(-1, -1, 0), Vec3(0.5f, 0.5f, 1e-30f), Vec3(0.5f, 0.5f, 1e-7f),
                     Vec3(1e30f, 0, 1e30f), Vec3(0, 0, 1e20f), Vec3(0, 0, 3e38f)}) {
        check_pdf_consistency(s, ref, 16);
        for (Vec3 p : {Vec3(0, 0, 0), Vec3(0.5f, 0.5f, 0), Vec3(-1, -1, 0)}) {
            float pdf = light_pdf(s, 0, 0, ref, p, Vec3(0, 0, 1), Vec3(0, 0, -1));
            EXPECT_TRUE(std::isfinite(pdf));
            EXPECT_GE(pdf, 0.0f);
        }
    }
    // A mesh light made only of degenerate triangles: no power, never chosen, no NaN.
    Scene d;
    Mesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    m.indices = {0, 1, 2, 0, 0, 1};
    add_mesh_light(d, m, RGB(1, 1, 1));
    add_point_light(d, {0, 0, 1}, RGB(1, 1, 1));
    lights_prepare(d);
    EXPECT_EQ(d.lights[0].area, 0.0f);
    EXPECT_EQ(light_selection_pmf(d, 0), 0.0f);
    EXPECT_EQ(light_selection_pmf(d, 1), 1.0f);
    for (float u : {0.0f, 0.5f, kOneMinusEps}) {
        LightSample ls;
        ASSERT_TRUE(sample_light(d, {0, 1, 1}, u, {0.5f, 0.5f}, &ls));
        EXPECT_EQ(ls.light, 1u);
    }
    EXPECT_EQ(light_pdf(d, 0, 0, {0, 1, 1}, {0.5f, 0, 0}, {0, 0, 1}, {0, -1, 0}), 0.0f);
}

TEST(Lights, SphereFromOutsideMatchesAndLiesOnVisibleCap) {
    for (float r : {1.0f, 0.2f, 0.0333f}) {
        Scene s;
        Vec3 c(0.5f, -0.3f, 2.0f);
        add_sphere_light(s, c, r, RGB(1, 2, 3));
        lights_prepare(s);
        Vec3 ref(0, 0, 0);
        for (Vec3 rp : {ref, Vec3(0.5f, -0.3f, 2.0f - 1.001f * r), Vec3(0.5f, -0.3f + 1.5f * r, 2.0f)}) {
            EXPECT_GT(check_pdf_consistency(s, rp, 30), 900) << r;
            double d = length(c - rp);
            double s2 = double(r) * r / (d * d);
            double cone = 1.0 / (2 * M_PI * (1 - std::sqrt(1 - s2)));
            Rng rng(15, 16);
            for (int i = 0; i < 2000; ++i) {
                LightSample ls;
                ASSERT_TRUE(sample_light(s, rp, rng.next_float(), {rng.next_float(), rng.next_float()}, &ls));
                EXPECT_NEAR(ls.pdf, cone, 1e-5 * cone);
                EXPECT_NEAR(length(ls.p - c), r, 2e-6f * std::max(1.0f, float(d)));
                EXPECT_GT(dot(ls.n, -ls.wi), 0.0f);  // facing the reference point
                // The ray along wi reaches the sphere first at the sampled point.
                auto t = ray_sphere(rp, ls.wi, c, r);
                ASSERT_TRUE(t.has_value());
                EXPECT_NEAR(*t, ls.dist, 1e-4 * std::max(1.0, d));
            }
        }
    }
}

TEST(Lights, SphereFromInsideUsesAreaSampling) {
    Scene s;
    Vec3 c(0, 0, 0);
    add_sphere_light(s, c, 2.0f, RGB(1, 1, 1), /*flip=*/true);  // emits inwards
    lights_prepare(s);
    Vec3 ref(0.3f, -0.5f, 0.8f);
    EXPECT_GT(check_pdf_consistency(s, ref, 30), 3000);
    Rng rng(17, 18);
    for (int i = 0; i < 2000; ++i) {
        LightSample ls;
        ASSERT_TRUE(sample_light(s, ref, rng.next_float(), {rng.next_float(), rng.next_float()}, &ls));
        EXPECT_NEAR(length(ls.p - c), 2.0f, 1e-5f);
        EXPECT_NEAR(dot(ls.n, -normalize(ls.p - c)), 1.0f, 1e-5f);  // flipped normal points inwards
        double cos_l = dot(ls.n, -ls.wi);
        double expected = double(ls.dist) * ls.dist / (4 * M_PI * 4.0 * cos_l);
        EXPECT_NEAR(ls.pdf, expected, 1e-4 * expected);
    }
    // Not flipped: from inside nothing is visible.
    s.spheres[0].flip_normals = false;
    EXPECT_EQ(check_pdf_consistency(s, ref, 10), 0);
    EXPECT_EQ(light_pdf(s, 0, 0, ref, Vec3(2, 0, 0), Vec3(1, 0, 0), normalize(Vec3(2, 0, 0) - ref)), 0.0f);
}

TEST(Lights, SphereNoNanAtSurfaceCentreAndFarAway) {
    Scene s;
    Vec3 c(1, 2, 3);
    const float r = 0.75f;
    add_sphere_light(s, c, r, RGB(1, 1, 1));
    add_sphere_light(s, c + Vec3(5, 0, 0), r, RGB(1, 1, 1), true);
    lights_prepare(s);
    Rng rng(19, 20);
    std::vector<Vec3> refs = {c, c + Vec3(5, 0, 0), Vec3(1e30f, 0, 0), Vec3(0, -3e38f, 0), c + Vec3(0, 0, r),
                              c + Vec3(5, r, 0)};
    for (int i = 0; i < 20; ++i) {
        Vec3 dir = normalize(Vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
        refs.push_back(c + dir * r);  // exactly on the surface, up to float rounding either side
        refs.push_back(c + Vec3(5, 0, 0) + dir * r);
    }
    for (Vec3 ref : refs) {
        check_pdf_consistency(s, ref, 12);
        for (uint32_t li = 0; li < 2; ++li) {
            Vec3 cc = s.spheres[li].center;
            Vec3 p = cc + Vec3(0, r, 0);
            float pdf = light_pdf(s, li, 0, ref, p, Vec3(0, 1, 0), normalize(p - ref));
            EXPECT_TRUE(std::isfinite(pdf));
            EXPECT_GE(pdf, 0.0f);
        }
    }
}

TEST(Lights, TinySpherePdfIsAccurate) {
    // The veach_mi small light: r = 0.0333 seen from about 15 units, 1 - cos(theta_max) = 2.5e-6. In
    // float, 1 - sqrt(1 - s^2) would be off by up to ~2 %; the reference here is long double.
    struct Case {
        float r;
        Vec3 c;
    };
    // The last cases are beyond float's reach for positions (the sphere is a few ULPs of its distance
    // across), but the pdf must still be right: it depends only on r and d.
    for (Case k : {Case{0.0333f, Vec3(0.3f, 4.0f, 14.5f)}, Case{1e-3f, Vec3(0, 0, 300)}, Case{1e-2f, Vec3(7, -3, 100)}}) {
        Scene s;
        add_sphere_light(s, k.c, k.r, RGB(1, 1, 1));
        lights_prepare(s);
        Vec3 ref(0.1f, -0.2f, 0.05f);
        long double dx = (long double)k.c.x - ref.x, dy = (long double)k.c.y - ref.y, dz = (long double)k.c.z - ref.z;
        long double d2 = dx * dx + dy * dy + dz * dz, rr = (long double)k.r * k.r;
        long double omc = 1.0L - std::sqrt(1.0L - rr / d2);
        double expected = double(1.0L / (2.0L * 3.14159265358979323846264338327950288L * omc));
        LightSample ls;
        ASSERT_TRUE(sample_light(s, ref, 0.5f, {0.25f, 0.75f}, &ls));
        EXPECT_NEAR(ls.pdf, expected, 1e-6 * expected) << "r = " << k.r;
        EXPECT_EQ(light_pdf(s, 0, ls.prim, ref, ls.p, ls.n, ls.wi), ls.pdf);
        // Samples spread over the whole visible disk: the rim direction is at theta_max (checked where
        // float directions can resolve the disk).
        if (rr / d2 < 1e-6L) continue;
        ASSERT_TRUE(sample_light(s, ref, 0.5f, {kOneMinusEps, 0.1f}, &ls));
        Vec3 axis = normalize(k.c - ref);
        double cos_t = dot(ls.wi, axis);
        double sin_t = length(cross(ls.wi, axis));
        double sin_max = std::sqrt(double(rr / d2));
        EXPECT_NEAR(sin_t / sin_max, 1.0, 2e-3) << "r = " << k.r;
        EXPECT_GT(cos_t, 0.99);
    }
}

TEST(Lights, PointLight) {
    Scene s;
    uint32_t pt = add_point_light(s, {0, 0, 2}, RGB(8, 4, 2));
    add_mesh_light(s, quad_mesh({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}), RGB(1, 1, 1));
    lights_prepare(s);
    Vec3 ref(0, 0, 1);
    EXPECT_GT(check_pdf_consistency(s, ref, 20), 0);
    float pmf = light_selection_pmf(s, pt);
    // u_sel = 0 picks the first light with positive weight: the point light.
    LightSample ls;
    ASSERT_TRUE(sample_light(s, ref, 0.0f, {0.5f, 0.5f}, &ls));
    ASSERT_EQ(ls.light, pt);
    EXPECT_TRUE(ls.delta);
    EXPECT_EQ(ls.pdf, pmf);
    EXPECT_NEAR(ls.dist, 1.0f, 1e-6f);
    EXPECT_NEAR(ls.wi.z, 1.0f, 1e-6f);
    EXPECT_NEAR(ls.radiance.r, 8.0f, 1e-5f);  // I / d^2 with d = 1
    ASSERT_TRUE(sample_light(s, Vec3(0, 0, 0), 0.0f, {0.5f, 0.5f}, &ls));
    EXPECT_NEAR(ls.radiance.g, 1.0f, 1e-6f);  // 4 / 2^2
    EXPECT_EQ(light_pdf(s, pt, ls.prim, ref, ls.p, ls.n, ls.wi), pmf);
    EXPECT_EQ(light_emitted(s.lights[pt], {0, 0, 1}, {0, 0, 1}).r, 0.0f);
    // At the light itself: no sample, no NaN.
    EXPECT_FALSE(sample_light(s, Vec3(0, 0, 2), 0.0f, {0.5f, 0.5f}, &ls));
    EXPECT_EQ(ls.pdf, 0.0f);
}

TEST(Lights, ConstantEnvironment) {
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}), RGB(1, 1, 1));
    uint32_t env = add_constant_light(s, RGB(0.5f, 0.5f, 0.5f));
    lights_prepare(s);
    EXPECT_EQ(s.environment_light, int(env));
    float pmf = light_selection_pmf(s, env);
    EXPECT_GT(pmf, 0.0f);
    Rng rng(21, 22);
    int env_samples = 0;
    for (int i = 0; i < 5000; ++i) {
        LightSample ls;
        Vec3 ref(0.1f, 0.2f, 0.5f);
        if (!sample_light(s, ref, rng.next_float(), {rng.next_float(), rng.next_float()}, &ls)) continue;
        EXPECT_EQ(light_pdf(s, ls.light, ls.prim, ref, ls.p, ls.n, ls.wi), ls.pdf);
        if (ls.light != env) continue;
        ++env_samples;
        EXPECT_EQ(ls.dist, kInf);
        EXPECT_FALSE(ls.delta);
        EXPECT_FLOAT_EQ(ls.pdf, pmf * kInv4Pi);
        EXPECT_NEAR(length(ls.wi), 1.0f, 1e-5f);
        EXPECT_EQ(ls.radiance.r, 0.5f);
    }
    EXPECT_GT(env_samples, 100);
    EXPECT_FLOAT_EQ(light_pdf(s, env, 0, {}, {}, {}, Vec3(0, 0, -1)), pmf * kInv4Pi);
    for (Vec3 w : {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 0, 0)}) {
        EXPECT_EQ(light_emitted(s.lights[env], Vec3(0), w).g, 0.5f);
    }
    // Two environment lights are an error.
    add_constant_light(s, RGB(1, 1, 1));
    EXPECT_THROW(lights_prepare(s), std::runtime_error);
}

TEST(Lights, MixturePdfIncludesSelection) {
    Scene s;
    add_mesh_light(s, quad_mesh({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}), RGB(3, 3, 3));
    add_sphere_light(s, {0, 0, 4}, 0.5f, RGB(1, 5, 1));
    add_sphere_light(s, {0, 0, 4}, 0.1f, RGB(1, 5, 1));  // inside the other one: seen from outside too
    add_point_light(s, {1, 1, 1}, RGB(1, 1, 1));
    add_constant_light(s, RGB(0.1f, 0.1f, 0.1f));
    lights_prepare(s);
    EXPECT_GT(check_pdf_consistency(s, Vec3(0.2f, 0.3f, 1.0f), 30), 3000);
    float sum = 0;
    for (uint32_t i = 0; i < s.lights.size(); ++i) sum += light_selection_pmf(s, i);
    EXPECT_NEAR(sum, 1.0f, 1e-6f);
    // An empty scene samples nothing.
    Scene none;
    lights_prepare(none);
    LightSample ls;
    EXPECT_FALSE(sample_light(none, {0, 0, 0}, 0.5f, {0.5f, 0.5f}, &ls));
    EXPECT_EQ(light_pdf(none, 0, 0, {}, {}, {}, {}), 0.0f);
}

}  // namespace
}  // namespace iris
