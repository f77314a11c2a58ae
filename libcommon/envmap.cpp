// The environment map light (Mitsuba 0.5's envmap): an equirectangular image, sampled by its texels'
// luminance times sin(theta), with the density of a direction exactly the one it was sampled with
// (declared in lights.h; moved out of lights.cpp to keep that file within the size limit).
#include <algorithm>
#include <cfloat>
#include <cmath>

#include "libcommon/lights.h"

namespace iris {

namespace {

constexpr double kPiD = 3.14159265358979323846;

// Largest density we report: beyond it a float pdf would be infinite (as lights.cpp).
constexpr double kMaxPdf = double(FLT_MAX);

// Map-local direction -> (u, v) in [0,1)^2 and the texel it falls in (Mitsuba 0.5's latlong).
struct EnvCoord {
    int col = 0, row = 0;
    float sin_theta = 0;
};
EnvCoord env_coord(const EnvMap& m, Vec3 d_world) {
    Vec3 d = m.to_local.vector(d_world);
    float len = length(d);
    EnvCoord c;
    if (!(len > 0) || !std::isfinite(len)) return c;
    d = d / len;
    float u = std::atan2(d.x, -d.z) * kInv2Pi;
    if (u < 0) u += 1.0f;
    float v = safe_acos(d.y) * kInvPi;
    c.col = std::min(m.width - 1, std::max(0, int(u * float(m.width))));
    c.row = std::min(m.height - 1, std::max(0, int(v * float(m.height))));
    // From x and z, not 1 - y^2: near the poles y rounds to +-1 while sin(theta) is still ~1e-5.
    c.sin_theta = std::sqrt(d.x * d.x + d.z * d.z);
    return c;
}

// A light sample from a point in space (point and spot lights): a delta in position, so pdf 1 and

}  // namespace

std::shared_ptr<const EnvMap> make_envmap(int width, int height, std::vector<RGB> texels, const Transform& to_world) {
    if (width <= 0 || height <= 0) throw std::invalid_argument("environment map of size " + std::to_string(width) +
                                                                " x " + std::to_string(height));
    if (texels.size() != size_t(width) * size_t(height))
        throw std::invalid_argument("environment map: texel count does not match its size");
    auto m = std::make_shared<EnvMap>();
    m->width = width;
    m->height = height;
    m->to_world = to_world;
    m->to_local = to_world.inverse();
    std::vector<float> row_w(static_cast<size_t>(height), 0.0f), col_w(static_cast<size_t>(width));
    m->cols.resize(size_t(height));
    double acc[3] = {0, 0, 0};
    const double dphi = 2.0 * kPiD / width;
    for (int y = 0; y < height; ++y) {
        // Solid angle of a texel of this row: dphi (cos theta0 - cos theta1), in sr.
        const double t0 = kPiD * y / height, t1 = kPiD * (y + 1) / height;
        const double omega = dphi * (std::cos(t0) - std::cos(t1));
        const float sin_c = float(std::sin(kPiD * (y + 0.5) / height));
        double sum = 0;
        for (int x = 0; x < width; ++x) {
            const RGB& t = texels[size_t(y) * width + x];
            if (!is_finite(t) || t.r < 0 || t.g < 0 || t.b < 0)
                throw std::invalid_argument("environment map: texel (" + std::to_string(x) + ", " + std::to_string(y) +
                                            ") is negative or not finite");
            col_w[size_t(x)] = luminance(t);
            sum += col_w[size_t(x)];
            acc[0] += t.r * omega;
            acc[1] += t.g * omega;
            acc[2] += t.b * omega;
        }
        m->cols[size_t(y)] = Distribution1D(col_w);
        row_w[size_t(y)] = float(sum * sin_c);
    }
    m->rows = Distribution1D(row_w);
    m->integral = RGB(float(acc[0]), float(acc[1]), float(acc[2]));
    if (!is_finite(m->integral)) throw std::invalid_argument("environment map: total radiance is not finite");
    m->texels = std::move(texels);
    return m;
}

RGB envmap_eval(const EnvMap& m, Vec3 d) {
    EnvCoord c = env_coord(m, d);
    return m.texels[size_t(c.row) * m.width + c.col];
}

float envmap_pdf(const EnvMap& m, Vec3 d) {
    if (m.rows.empty()) return 0.0f;
    EnvCoord c = env_coord(m, d);
    if (!(c.sin_theta > 0)) return 0.0f;
    // Uniform within the texel in (u, v); (u, v) -> direction has Jacobian 2 pi^2 sin(theta) sr.
    double p_uv = double(m.rows.pmf(uint32_t(c.row))) * m.cols[size_t(c.row)].pmf(uint32_t(c.col)) * m.width * m.height;
    double pdf = p_uv / (2.0 * kPiD * kPiD * c.sin_theta);
    return pdf < kMaxPdf ? float(pdf) : 0.0f;
}

bool envmap_sample(const EnvMap& m, Vec2 u, Vec3* d, float* pdf) {
    if (m.rows.empty()) return false;
    float ur, uc;
    const uint32_t row = m.rows.sample(u.x, &ur);
    const uint32_t col = m.cols[row].sample(u.y, &uc);
    const double phi = 2.0 * kPiD * (col + double(uc)) / m.width;
    const double theta = kPiD * (row + double(ur)) / m.height;
    const double st = std::sin(theta);
    Vec3 local(float(std::sin(phi) * st), float(std::cos(theta)), float(-std::cos(phi) * st));
    Vec3 w = m.to_world.vector(local);
    float len = length(w);
    if (!(len > 0)) return false;
    *d = w / len;
    *pdf = envmap_pdf(m, *d);
    return *pdf > 0;
}

}  // namespace iris
