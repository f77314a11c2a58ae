// The film's two estimators meet in one pixel value: camera samples by filter importance sampling
// (FilterSampler::sample's weights, normalised by their sum) and light-traced splats weighted by the
// filter's density (FilterSampler::density, what render's caustic light tracer uses). Both must
// integrate against the same normalised filter, or light-traced caustics would come out brighter or
// darker than the path tracer's.
#include <gtest/gtest.h>

#include <cmath>

#include "libcommon/camera.h"
#include "libcommon/film.h"
#include "libcommon/rng.h"

using namespace iris;

namespace {

FilmSettings gaussian_film() {
    FilmSettings f;
    f.filter = FilterType::Gaussian;
    f.filter_radius = 2.0f;
    f.filter_stddev = 0.5f;
    return f;
}

// Midpoint rule over the support: integral of density(o) * g(o).
template <class G>
double integrate_density(const FilterSampler& fs, G g) {
    constexpr int n = 800;
    const double r = fs.radius(), h = 2 * r / n;
    double sum = 0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const float x = float(-r + (i + 0.5) * h), y = float(-r + (j + 0.5) * h);
            sum += fs.density({x, y}) * g(x, y);
        }
    return sum * h * h;
}

// Filter importance sampling's ratio estimate of the same integral.
template <class G>
double estimate_by_sampling(const FilterSampler& fs, G g) {
    Rng rng(7, 1);
    double sw = 0, swg = 0;
    for (int k = 0; k < 1 << 20; ++k) {
        float w;
        const Vec2 o = fs.sample({rng.next_float(), rng.next_float()}, &w);
        sw += w;
        swg += w * g(o.x, o.y);
    }
    return swg / sw;
}

}  // namespace

TEST(FilterDensity, GaussianIntegratesToOneAndMatchesTheSampledFilter) {
    const FilterSampler fs(gaussian_film());
    EXPECT_FLOAT_EQ(fs.radius(), 2.0f);
    EXPECT_NEAR(integrate_density(fs, [](float, float) { return 1.0; }), 1.0, 1e-4);
    EXPECT_EQ(fs.density({2.01f, 0.0f}), 0.0f);
    EXPECT_GT(fs.density({0.0f, 0.0f}), fs.density({0.5f, 0.0f}));
    // Moments the camera samples see: E[x^2] and the mass right of x = 0.3.
    auto x2 = [](float x, float) { return double(x) * x; };
    auto right = [](float x, float y) { return x > 0.3f && y > -0.2f ? 1.0 : 0.0; };
    EXPECT_NEAR(integrate_density(fs, x2), estimate_by_sampling(fs, x2), 2e-3);
    EXPECT_NEAR(integrate_density(fs, right), estimate_by_sampling(fs, right), 2e-3);
}

TEST(FilterDensity, BoxIsOneInsideThePixel) {
    FilmSettings f;
    f.filter = FilterType::Box;
    const FilterSampler fs(f);
    EXPECT_FLOAT_EQ(fs.radius(), 0.5f);
    EXPECT_EQ(fs.density({0.49f, -0.49f}), 1.0f);
    EXPECT_EQ(fs.density({0.51f, 0.0f}), 0.0f);
}

// A pixel's value is the camera samples' weighted mean plus the light sum over every light path traced
// so far (light_paths_per_sample per sample pass); its variance adds the light paths' own.
TEST(FilmLight, ValueAddsTheLightSumOverAllPathsTraced) {
    Film film(2, 1);
    film.enable_light(4);
    for (int s = 0; s < 2; ++s) film.add(0, 0, RGB(1.0f), 1.0f);
    // 8 light paths in two passes: three of them splat pixel 0 (the others contribute zero).
    film.add_light(0, RGB(2.0f));
    film.add_light(0, RGB(4.0f));
    film.add_light(0, RGB(2.0f));
    EXPECT_FLOAT_EQ(film.value(0, 0).r, 1.0f + 8.0f / 8);
    // Light variance of the mean over 8 paths: (E[c^2] - E[c]^2) / 8 with E[c] = 1, E[c^2] = 24 / 8.
    EXPECT_NEAR(film.variance(0, 0).g, (3.0 - 1.0) / 8, 1e-6);
    EXPECT_FLOAT_EQ(film.value(1, 0).r, 0.0f);  // no camera sample yet: nothing
}

// The light tracer projects points onto the film with camera_film_position: the inverse of
// camera_direction, for film positions inside the image and across its edge.
TEST(CameraFilmPosition, InvertsCameraDirection) {
    Camera c;
    c.to_world = Transform::look_at(Vec3(1, 2, 3), Vec3(0, 0, 0), Vec3(0, 0, 1));
    c.fov_degrees = 50;
    camera_prepare(c, 64, 48);
    for (float fx : {-1.5f, 0.0f, 10.25f, 63.9f, 65.0f})
        for (float fy : {-0.5f, 7.5f, 47.9f}) {
            const Vec3 d = camera_direction(c, fx, fy, 64, 48);
            float gx, gy, cos_axis;
            ASSERT_TRUE(camera_film_position(c, d * 3.0f, 64, 48, &gx, &gy, &cos_axis));
            EXPECT_NEAR(gx, fx, 1e-3f);
            EXPECT_NEAR(gy, fy, 1e-3f);
            EXPECT_NEAR(cos_axis, dot(d, c.forward), 1e-6f);
        }
    float gx, gy, cos_axis;
    EXPECT_FALSE(camera_film_position(c, -c.forward, 64, 48, &gx, &gy, &cos_axis));
}
