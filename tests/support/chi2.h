// Chi-square goodness-of-fit testing of direction samplers against their claimed PDF (per steradian).
// The sphere is cut into a theta x phi grid; observed counts come from the sampler, expected counts
// from integrating the PDF over each cell by quadrature. Cells with small expectations are pooled,
// then Pearson's statistic is compared with the chi-square distribution; the significance level is
// Sidak-corrected for the number of tests in the suite. Samples that the sampler flags as discrete
// (delta lobes) are excluded from the histogram and from the expected mass (the PDF only describes
// the continuous part).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "libcommon/math.h"
#include "libcommon/rng.h"

namespace iris::test {

// Regularised upper incomplete gamma Q(a, x) (series for x < a+1, continued fraction otherwise).
inline double gamma_q(double a, double x) {
    if (x <= 0) return 1.0;
    double gln = std::lgamma(a);
    if (x < a + 1) {
        double ap = a, sum = 1.0 / a, del = sum;
        for (int n = 0; n < 10000; ++n) {
            ap += 1;
            del *= x / ap;
            sum += del;
            if (std::abs(del) < std::abs(sum) * 1e-15) break;
        }
        return 1.0 - sum * std::exp(-x + a * std::log(x) - gln);
    }
    double b = x + 1 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
    for (int i = 1; i < 10000; ++i) {
        double an = -i * (i - a);
        b += 2;
        d = an * d + b;
        if (std::abs(d) < 1e-300) d = 1e-300;
        c = b + an / c;
        if (std::abs(c) < 1e-300) c = 1e-300;
        d = 1.0 / d;
        double del = d * c;
        h *= del;
        if (std::abs(del - 1.0) < 1e-15) break;
    }
    return std::exp(-x + a * std::log(x) - gln) * h;
}

// One sample: a direction, and whether it came from a discrete (delta) lobe. `valid=false` = no sample.
struct DirSample {
    Vec3 w;
    bool valid = false;
    bool discrete = false;
};

struct Chi2Result {
    double statistic = 0, p_value = 1;
    int dof = 0;
    bool passed = false;
    std::string log;  // table dump and summary, printed by tests on failure
};

struct Chi2Options {
    int theta_bins = 10, phi_bins = 20;
    long long samples = 1000000;
    double min_expected = 5.0;       // pool cells below this
    double significance = 0.01;      // per suite, Sidak-corrected by `test_count`
    int test_count = 1;
    int quadrature = 6;              // quadrature points per cell side (midpoint rule, in cos-theta x phi)
    uint64_t seed = 7;
};

// sampler(rng) -> DirSample; pdf(w) -> density per steradian of the continuous part.
inline Chi2Result chi2_test_sphere(const std::function<DirSample(Rng&)>& sampler,
                                   const std::function<double(Vec3)>& pdf, const Chi2Options& o = {}) {
    const int nt = o.theta_bins, np = o.phi_bins, nc = nt * np;
    std::vector<double> observed(nc, 0.0), expected(nc, 0.0);
    Rng rng(o.seed, 1);
    long long discrete = 0;
    // Bins are uniform in cos(theta) in [-1, 1] and phi in [0, 2 pi): equal solid angle per cell.
    auto cell_of = [&](Vec3 w) {
        float z = clamp(w.z, -1.0f, 1.0f);
        int ti = std::min(nt - 1, int((1.0f - z) * 0.5f * nt));
        float phi = std::atan2(w.y, w.x);
        if (phi < 0) phi += 2 * kPi;
        int pi = std::min(np - 1, int(phi / (2 * kPi) * np));
        return ti * np + pi;
    };
    for (long long i = 0; i < o.samples; ++i) {
        DirSample s = sampler(rng);
        if (!s.valid) continue;
        if (s.discrete) {
            ++discrete;
            continue;
        }
        observed[cell_of(s.w)] += 1;
    }
    const int q = o.quadrature;
    const double cell_sa = 4.0 * M_PI / nc;
    for (int ti = 0; ti < nt; ++ti)
        for (int pi = 0; pi < np; ++pi) {
            double sum = 0;
            for (int a = 0; a < q; ++a)
                for (int b = 0; b < q; ++b) {
                    double z = 1.0 - 2.0 * (ti + (a + 0.5) / q) / nt;
                    double phi = 2 * M_PI * (pi + (b + 0.5) / q) / np;
                    double r = std::sqrt(std::max(0.0, 1 - z * z));
                    sum += pdf(Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
                }
            expected[ti * np + pi] = sum / (q * q) * cell_sa * double(o.samples);
        }
    // Pool cells with small expectation (sorted ascending) into one bin.
    std::vector<int> order(nc);
    for (int i = 0; i < nc; ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](int a, int b) { return expected[a] < expected[b]; });
    double pool_obs = 0, pool_exp = 0, stat = 0;
    int bins = 0;
    for (int i : order) {
        if (expected[i] < o.min_expected) {
            pool_obs += observed[i];
            pool_exp += expected[i];
            continue;
        }
        stat += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
        ++bins;
    }
    if (pool_exp > 0 || pool_obs > 0) {
        if (pool_exp < o.min_expected) {
            // The pool is too small for the asymptotics: it only fails the test if it is badly off.
            if (pool_obs > o.min_expected * 4 + pool_exp * 4) stat += 1e9;
        } else {
            stat += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
            ++bins;
        }
    }
    Chi2Result r;
    r.dof = std::max(1, bins - 1);
    r.statistic = stat;
    r.p_value = gamma_q(r.dof / 2.0, stat / 2.0);
    double alpha = 1.0 - std::pow(1.0 - o.significance, 1.0 / o.test_count);
    r.passed = r.p_value > alpha;
    char buf[256];
    std::snprintf(buf, sizeof buf, "chi2 = %.3f, dof = %d, p = %.4g (threshold %.3g), discrete samples %lld\n",
                  stat, r.dof, r.p_value, alpha, discrete);
    r.log = buf;
    if (!r.passed) {
        r.log += "cell (theta,phi): observed / expected\n";
        for (int ti = 0; ti < nt; ++ti) {
            for (int pi = 0; pi < np; ++pi) {
                std::snprintf(buf, sizeof buf, "%6.0f/%-8.1f ", observed[ti * np + pi], expected[ti * np + pi]);
                r.log += buf;
            }
            r.log += "\n";
        }
    }
    return r;
}

// Integral of pdf over the sphere by the same quadrature (should be <= 1; = 1 minus the delta mass).
inline double integrate_sphere(const std::function<double(Vec3)>& pdf, int n_theta = 200, int n_phi = 400) {
    double sum = 0;
    for (int i = 0; i < n_theta; ++i)
        for (int j = 0; j < n_phi; ++j) {
            double z = 1.0 - 2.0 * (i + 0.5) / n_theta;
            double phi = 2 * M_PI * (j + 0.5) / n_phi;
            double r = std::sqrt(std::max(0.0, 1 - z * z));
            sum += pdf(Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
        }
    return sum * 4 * M_PI / (double(n_theta) * n_phi);
}

}  // namespace iris::test
