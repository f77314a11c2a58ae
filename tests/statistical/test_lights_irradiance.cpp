// Next event estimation of the irradiance from a quad light, against Lambert's closed form for a
// polygon, E = L/2 |sum_i theta_i (n . unit(v_i x v_i+1))| (v_i: unit directions to the outline's
// vertices, theta_i: the angle between neighbours, n: the receiver's normal; valid where the whole
// polygon lies above the receiver's horizon). The estimate is the mean of L cos / pdf over
// sample_light's points, so it is unbiased only if the points follow the reported pdf: this checks
// the solid-angle sampling of near triangles (a wrong warp or a wrong solid angle shifts the mean)
// and the area sampling of far ones, mixed in one tessellated light, with no ray tracing involved.
// Seeds are fixed; the 5-sigma bound keeps the false-alarm rate of the 6 comparisons below 1e-5.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "libcommon/lights.h"
#include "libcommon/rng.h"
#include "libcommon/scene.h"

namespace iris {
namespace {

// The square [-1, 1]^2 at z = 0 as a grid of n x n cells, two triangles each, emitting towards +z.
void add_grid_light(Scene& s, int n, RGB radiance) {
    Mesh m;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) m.positions.push_back(Vec3(-1.0f + 2.0f * i / n, -1.0f + 2.0f * j / n, 0.0f));
    auto at = [&](int i, int j) { return uint32_t(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    m.light = 0;
    s.meshes.push_back(std::move(m));
    Light l;
    l.type = LightType::AreaMesh;
    l.shape = 0;
    l.radiance = radiance;
    s.lights.push_back(l);
    lights_prepare(s);
}

double lambert_irradiance(double radiance, Vec3 ref, Vec3 n) {
    const double corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    double v[4][3];
    for (int k = 0; k < 4; ++k) {
        double d[3] = {corners[k][0] - ref.x, corners[k][1] - ref.y, -double(ref.z)};
        double l = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int c = 0; c < 3; ++c) v[k][c] = d[c] / l;
    }
    double sum = 0;
    for (int k = 0; k < 4; ++k) {
        const double* a = v[k];
        const double* b = v[(k + 1) % 4];
        double g[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
        double gl = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        double theta = std::atan2(gl, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
        sum += theta * (n.x * g[0] + n.y * g[1] + n.z * g[2]) / gl;
    }
    return 0.5 * radiance * std::abs(sum);
}

struct Case {
    Vec3 ref, normal;
    const char* what;
};

TEST(LightIrradiance, NeeMatchesLambertsFormula) {
    Scene s;
    add_grid_light(s, 8, RGB(3, 3, 3));
    const Case cases[] = {
        {Vec3(0.1f, 0.2f, 0.05f), Vec3(0, 0, -1), "just above the light: near triangles in solid angle, far ones by area"},
        {Vec3(0.0f, 0.0f, 0.6f), Vec3(0, 0, -1), "above the centre"},
        {Vec3(0.0f, 0.0f, 1.0f), normalize(Vec3(0.3f, 0, -1)), "tilted receiver"},
        {Vec3(0.95f, -0.95f, 0.02f), Vec3(0, 0, -1), "above a corner, almost on the plane"},
        {Vec3(1.5f, 0.3f, 0.3f), normalize(Vec3(-1, 0, -1)), "beside the light"},
        {Vec3(0.5f, 0.5f, 12.0f), Vec3(0, 0, -1), "far: every triangle by area"},
    };
    const int n = 400000;
    Rng rng(71, 72);
    for (const Case& c : cases) {
        double sum = 0, sum2 = 0;
        for (int i = 0; i < n; ++i) {
            LightSample ls;
            double x = 0;
            if (sample_light(s, c.ref, rng.next_float(), {rng.next_float(), rng.next_float()}, &ls))
                x = double(ls.radiance.r) * std::max(0.0f, dot(ls.wi, c.normal)) / double(ls.pdf);
            sum += x;
            sum2 += x * x;
        }
        const double mean = sum / n, sigma = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
        const double expected = lambert_irradiance(3.0, c.ref, c.normal);
        std::printf("    %s: NEE %.6f +- %.6f, Lambert %.6f\n", c.what, mean, sigma, expected);
        EXPECT_NEAR(mean, expected, 5.0 * sigma + 1e-6 * expected) << c.what;
    }
}

}  // namespace
}  // namespace iris
