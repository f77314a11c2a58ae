// Spherical density maps: filter precomputation, splatting, flooring and the sampling tables
// (see spheremap.h for the layout, the measures and the reasons).
#include "libcommon/spheremap.h"
#include "libcommon/mutation.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace iris {

namespace {

void check_resolution(int R) {
    // 256^2 texels keeps every index and tap count far inside int.
    if (R < 1 || R > 256)
        throw std::invalid_argument("sphere map: resolution " + std::to_string(R) + " outside [1, 256]");
}

struct Dir {
    double x, y, z;
};

// Texel centre directions in double, renormalised (the float map is unit to ~1e-7).
std::vector<Dir> texel_centers(int R) {
    std::vector<Dir> c(size_t(R) * R);
    for (int j = 0; j < R; ++j)
        for (int i = 0; i < R; ++i) {
            Vec3 w = sphere_texel_center(i, j, R);
            double x = w.x, y = w.y, z = w.z, l = std::sqrt(x * x + y * y + z * z);
            c[size_t(j) * R + i] = {x / l, y / l, z / l};
        }
    return c;
}

}  // namespace

// ---- SphereFilter -----------------------------------------------------------------------------------

SphereFilter::SphereFilter(int R, float sigma) : R_(R), sigma_(sigma) {
    check_resolution(R);
    if (!std::isfinite(sigma)) throw std::invalid_argument("sphere filter: sigma must be finite");
    const int n = R * R;
    const std::vector<Dir> c = texel_centers(R);
    // Support: centres within 3 sigma of each other. Angles are computed as 2 asin(chord / 2), which is
    // accurate for small angles (acos of a dot product is not) and symmetric in the two texels, so the
    // neighbour relation is symmetric and mirror-symmetric layouts give mirror-symmetric filters.
    const double radius = 3.0 * double(sigma);
    const bool everything = radius >= M_PI;
    // Chord length of the support radius, slightly enlarged: only a cheap pre-test before the angle.
    const double chord_max = everything ? 2.0 : 2.0 * std::sin(0.5 * radius) * (1.0 + 1e-6) + 1e-12;
    const double inv_two_sigma2 = sigma > 0 ? 1.0 / (2.0 * double(sigma) * double(sigma)) : 0.0;
    auto for_each_neighbour = [&](int s, auto&& fn) {
        if (sigma <= 0) {
            fn(s, 1.0);
            return;
        }
        for (int t = 0; t < n; ++t) {
            double dx = c[t].x - c[s].x, dy = c[t].y - c[s].y, dz = c[t].z - c[s].z;
            double chord = std::sqrt(dx * dx + dy * dy + dz * dz);
            if (chord > chord_max) continue;
            double theta = 2.0 * std::asin(std::min(1.0, 0.5 * chord));
            if (theta > radius && t != s) continue;
            fn(t, std::exp(-theta * theta * inv_two_sigma2));
        }
    };
    // Pass 1: each source's total weight W_s (its taps then get w_st / W_s, summing to 1).
    std::vector<double> total(size_t(n), 0.0);
    std::vector<int> count(size_t(n), 0);
    for (int s = 0; s < n; ++s)
        for_each_neighbour(s, [&](int t, double w) {
            total[size_t(s)] += w;
            ++count[size_t(t)];
        });
    // Pass 2: the transposed (gather) table. The relation is symmetric, so target t's sources are the
    // texels within 3 sigma of t; the weights use the SOURCE's normaliser.
    row_begin_.assign(size_t(n) + 1, 0);
    for (int t = 0; t < n; ++t) row_begin_[size_t(t) + 1] = row_begin_[size_t(t)] + count[size_t(t)];
    src_.assign(size_t(row_begin_[size_t(n)]), 0);
    weight_.assign(src_.size(), 0.0f);
    std::vector<int> fill(row_begin_.begin(), row_begin_.end() - 1);
    for (int s = 0; s < n; ++s)
        for_each_neighbour(s, [&](int t, double w) {
            int at = fill[size_t(t)]++;
            src_[size_t(at)] = s;
            weight_[size_t(at)] = float(w / total[size_t(s)]);
        });
}

void SphereFilter::apply(const float* in, float* out) const {
    const int n = R_ * R_;
    for (int t = 0; t < n; ++t) {
        float sum = 0.0f;
        for (int a = row_begin_[size_t(t)], e = row_begin_[size_t(t) + 1]; a < e; ++a)
            sum += weight_[size_t(a)] * in[src_[size_t(a)]];
        out[t] = sum;
    }
}

// ---- SphereMap --------------------------------------------------------------------------------------

SphereMap::SphereMap(int R) : R_(R) {
    check_resolution(R);
    w_.assign(size_t(R) * R, 0.0f);
}

double SphereMap::total() const {
    double s = 0;
    for (float v : w_) s += v;
    return s;
}

void SphereMap::splat(Vec3 w, float value) {
    const Vec2 uv = sphere_to_square(w);
    // Continuous texel coordinate with texel centres at integers: texel i spans [i - 0.5, i + 0.5).
    const float x = uv.x * float(R_) - 0.5f, y = uv.y * float(R_) - 0.5f;
    const float x0 = std::floor(x), y0 = std::floor(y);
    const float fx = x - x0, fy = y - y0;  // in [0, 1]
    const int i = int(x0), j = int(y0);    // in [-1, R-1]: the +1 / -1 texels may lie across a fold
    w_[size_t(texel_neighbour(i, j, 0, 0))] += value * (1.0f - fx) * (1.0f - fy);
    w_[size_t(texel_neighbour(i, j, 1, 0))] += value * fx * (1.0f - fy);
    w_[size_t(texel_neighbour(i, j, 0, 1))] += value * (1.0f - fx) * fy;
    w_[size_t(texel_neighbour(i, j, 1, 1))] += value * fx * fy;
}

void SphereMap::filter(const SphereFilter& f) {
    if (f.resolution() != R_)
        throw std::invalid_argument("sphere map: filter resolution " + std::to_string(f.resolution()) +
                                    " does not match map resolution " + std::to_string(R_));
    scratch_.resize(w_.size());
    f.apply(w_.data(), scratch_.data());
    w_.swap(scratch_);
}

void SphereMap::gaussian_filter(float sigma) { filter(SphereFilter(R_, sigma)); }

void SphereMap::normalise_floor(float f) {
    if (!(f >= 0.0f && f <= 1.0f))
        throw std::invalid_argument("sphere map: floor fraction " + std::to_string(f) + " outside [0, 1]");
    const double n = double(w_.size());
    const double sum = total();
    if (!(sum > 0.0) || !std::isfinite(sum)) {
        // No information: the uniform density, the only choice that favours no direction.
        std::fill(w_.begin(), w_.end(), float(1.0 / n));
        return;
    }
    const double scale = (1.0 - double(f)) / sum, base = double(f) / n;
    double check = 0;
    for (float& v : w_) {
        v = float(double(v) * scale + base);
        check += v;
    }
    // Rounding to float leaves the sum ~1e-7 off 1; rescale once. This keeps every texel >= f/N up to
    // one rounding (the factor is 1 +- 1e-7).
    const float fix = float(1.0 / check);
    for (float& v : w_) v *= fix;
}

// ---- SphereDistribution -----------------------------------------------------------------------------

SphereDistribution::SphereDistribution(const SphereMap& map) : SphereDistribution(map.data(), map.resolution()) {}

SphereDistribution::SphereDistribution(const float* weights, int R) : R_(R) {
    check_resolution(R);
    cdf_.resize(size_t(R) * R);
    pdf_.resize(size_t(R) * R);
    build(weights, R, cdf_.data(), pdf_.data());
}

void SphereDistribution::build(const float* weights, int R, float* cdf, float* pdf) {
    check_resolution(R);
    const int n = R * R;
    double total = 0;
    int last_positive = -1;
    for (int k = 0; k < n; ++k) {
        const float w = weights[k];
        if (!(w >= 0.0f) || !std::isfinite(w))
            throw std::invalid_argument("sphere distribution: weight " + std::to_string(k) + " is " +
                                        std::to_string(w) + " (must be finite and >= 0)");
        total += w;
        if (w > 0) last_positive = k;
    }
    const float per_sr = float(n) * kInv4Pi;  // pmf -> density per steradian (texel = 4 pi / N sr)
    if (last_positive < 0) {
        // All zero: uniform, the same fallback as SphereMap::normalise_floor.
        for (int k = 0; k < n; ++k) cdf[k] = float(double(k + 1) / n);
        cdf[n - 1] = 1.0f;
    } else {
        double acc = 0;
        float prev = 0.0f;
        for (int k = 0; k < n; ++k) {
            acc += weights[k];
            float c;
            if (k >= last_positive) {
                // The last texel of positive weight ends exactly at 1, and the zero texels after it
                // stay at 1: their probability is exactly 0.
                c = 1.0f;
            } else if (weights[k] == 0.0f) {
                c = prev;  // exactly zero probability
            } else {
                // Rounded cumulative sum, kept strictly above the previous entry so that a tiny
                // positive weight never rounds to an empty interval (and to a zero density).
                c = std::max(float(acc / total), std::nextafter(prev, 2.0f));
                c = std::min(c, 1.0f);
            }
            cdf[k] = c;
            prev = c;
        }
    }
    // The pmf is defined by the stored cdf (see the class comment).
    float prev = 0.0f;
    for (int k = 0; k < n; ++k) {
        pdf[k] = (cdf[k] - prev) * per_sr;
        if (IRIS_MUTANT(spheremap_pdf_skew) && (k & 1)) pdf[k] *= 1.1f;
        prev = cdf[k];
    }
}

}  // namespace iris
