#include "libguide/bsdf_fraction.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "libcommon/spheremap.h"

namespace iris {

BsdfFractionChooser::BsdfFractionChooser(int R, double floor, float min_alpha) {
    if (R < 1) throw std::invalid_argument("BsdfFractionChooser: resolution must be positive");
    if (!(floor >= 0 && floor < 1)) throw std::invalid_argument("BsdfFractionChooser: floor must be in [0, 1)");
    if (!(min_alpha > 0 && min_alpha <= 1)) throw std::invalid_argument("BsdfFractionChooser: min_alpha must be in (0, 1]");
    N_ = R * R;
    omega_ = sphere_texel_solid_angle(R);
    floor_density_ = float(floor / (4.0 * M_PI));
    unfloor_scale_ = float(1.0 / (1.0 - floor));
    // Texel-mean cosine density from a 4x4 grid of points per texel (the texels near the horizon are cut
    // by it; their centre alone would misjudge them).
    constexpr int kSub = 4;
    cosine_.assign(size_t(N_), 0.0f);
    for (int j = 0; j < R; ++j)
        for (int i = 0; i < R; ++i) {
            double sum = 0;
            for (int b = 0; b < kSub; ++b)
                for (int a = 0; a < kSub; ++a) {
                    Vec3 w = square_to_sphere({(i + (a + 0.5f) / kSub) / float(R), (j + (b + 0.5f) / kSub) / float(R)});
                    sum += std::max(0.0f, w.z) / M_PI;
                }
            cosine_[size_t(j * R + i)] = float(sum / (kSub * kSub));
        }
    for (float a : {0.1f, 0.15f, 0.2f, 0.25f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f})
        if (a >= min_alpha) alphas_.push_back(a);
    alphas_.push_back(1.0f);
}

BsdfFractionChoice BsdfFractionChooser::choose(const float* pdf) const {
    // g: the map without its floor, on the upper hemisphere, normalised to integrate to 1.
    double total = 0;
    for (int k = 0; k < N_; ++k)
        if (cosine_[size_t(k)] > 0) total += std::max(0.0f, pdf[k] - floor_density_) * unfloor_scale_;
    total *= omega_;
    if (!(total > 0) || !std::isfinite(total)) return {};
    const double g_scale = unfloor_scale_ / total;
    // Second moment of g / p_mix under p_mix, for every candidate alpha at once.
    double moment[16] = {};
    const size_t na = alphas_.size();
    for (int k = 0; k < N_; ++k) {
        const float c = cosine_[size_t(k)];
        if (!(c > 0)) continue;
        const double g = std::max(0.0f, pdf[k] - floor_density_) * g_scale;
        if (!(g > 0)) continue;
        for (size_t a = 0; a < na; ++a) {
            const double p = alphas_[a] * c + (1.0 - alphas_[a]) * pdf[k];
            moment[a] += omega_ * g * g / p;
        }
    }
    // Relative variance V = moment - 1; a floor keeps the ratio finite when g is exactly cosine.
    auto variance = [&](size_t a) { return std::max(moment[a] - 1.0, 1e-6); };
    size_t best = na - 1;
    for (size_t a = 0; a < na; ++a)
        if (variance(a) < variance(best)) best = a;
    BsdfFractionChoice out;
    out.alpha = alphas_[best];
    out.gain = float(variance(na - 1) / variance(best));
    return out;
}

}  // namespace iris
