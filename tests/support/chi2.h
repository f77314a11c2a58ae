// Chi-square goodness-of-fit testing of direction samplers against their claimed PDF (per steradian).
// The sphere is cut into a theta x phi grid; observed counts come from the sampler, expected counts
// from integrating the PDF over each cell by adaptive quadrature (integrate_patch: glossy lobes can
// be far narrower than a cell, which a fixed midpoint rule mis-weights). Cells with small expectations
// are pooled, then Pearson's statistic is compared with the chi-square distribution; the significance
// level is Sidak-corrected for the number of tests in the suite. Samples that the sampler flags as discrete
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
    // Adaptive refinement of each cell's integral (see integrate_patch): a cell is split in 2 x 2 while
    // the estimate changes by more than max(quad_rel_tol * value, quad_abs_counts / samples), at most
    // quad_max_depth times. Peaky PDFs (glossy lobes) need it; smooth ones stop at the first level.
    double quad_rel_tol = 1e-3;   // with Richardson extrapolation the actual error is far smaller
    double quad_abs_counts = 0.01;   // absolute tolerance in expected counts per cell
    int quad_max_depth = 7;
};

namespace detail {

// Midpoint rule with q x q points for the integral of g(x, y) dx dy over [x0, x1] x [y0, y1].
template <class G>
double rect_midpoint(const G& g, double x0, double x1, double y0, double y1, int q) {
    double sum = 0;
    for (int a = 0; a < q; ++a) {
        double x = x0 + (x1 - x0) * (a + 0.5) / q;
        for (int b = 0; b < q; ++b) sum += g(x, y0 + (y1 - y0) * (b + 0.5) / q);
    }
    return sum / (q * q) * (x1 - x0) * (y1 - y0);
}

// Adaptive refinement: `whole` is the rectangle's estimate at this level; its 2 x 2 children are
// estimated and recursed into while their sum disagrees with `whole` by more than
// max(rel_tol * value, abs_tol) (abs_tol is shared out among the children).
template <class G>
double rect_adaptive(const G& g, double x0, double x1, double y0, double y1, int q, double whole, double rel_tol,
                     double abs_tol, int depth) {
    const double xs[3] = {x0, 0.5 * (x0 + x1), x1}, ys[3] = {y0, 0.5 * (y0 + y1), y1};
    double part[4], fine = 0;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) fine += part[2 * i + j] = rect_midpoint(g, xs[i], xs[i + 1], ys[j], ys[j + 1], q);
    // Converged: return the Richardson extrapolation (the midpoint rule's error falls 4x per halving
    // for smooth integrands), which removes most of the bias the rule has at peaks. At the depth limit
    // (a discontinuity, where that error model does not hold) the plain finer estimate is kept.
    if (std::abs(fine - whole) <= std::max(abs_tol, rel_tol * std::abs(fine))) {
        double extrapolated = fine + (fine - whole) / 3;
        return extrapolated >= 0 || fine < 0 ? extrapolated : fine;
    }
    if (depth <= 0) return fine;
    double sum = 0;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
            sum += rect_adaptive(g, xs[i], xs[i + 1], ys[j], ys[j + 1], q, part[2 * i + j], rel_tol, abs_tol / 4,
                                 depth - 1);
    return sum;
}

template <class G>
double rect_integral(const G& g, double x0, double x1, double y0, double y1, int q, double rel_tol, double abs_tol,
                     int max_depth) {
    return rect_adaptive(g, x0, x1, y0, y1, q, rect_midpoint(g, x0, x1, y0, y1, q), rel_tol, abs_tol, max_depth);
}

inline Vec3 sphere_dir(double z, double phi) {
    double r = std::sqrt(std::max(0.0, 1 - z * z));
    return Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
}

}  // namespace detail

// Integral of f (per steradian) over the patch [z0, z1] x [p0, p1] of (cos theta, phi), by the midpoint
// rule with q x q points, refined adaptively (2 x 2 splits, up to max_depth levels) until successive
// estimates agree to max(rel_tol * value, abs_tol). dz dphi is the solid-angle measure.
inline double integrate_patch(const std::function<double(Vec3)>& f, double z0, double z1, double p0, double p1,
                              int q, double rel_tol, double abs_tol, int max_depth) {
    auto g = [&](double z, double phi) { return f(detail::sphere_dir(z, phi)); };
    return detail::rect_integral(g, z0, z1, p0, p1, q, rel_tol, abs_tol, max_depth);
}

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
    const double abs_tol = o.quad_abs_counts / double(o.samples);
    for (int ti = 0; ti < nt; ++ti)
        for (int pi = 0; pi < np; ++pi) {
            double z0 = 1.0 - 2.0 * (ti + 1) / nt, z1 = 1.0 - 2.0 * ti / nt;
            double p0 = 2 * M_PI * pi / np, p1 = 2 * M_PI * (pi + 1) / np;
            double mass = integrate_patch(pdf, z0, z1, p0, p1, o.quadrature, o.quad_rel_tol, abs_tol,
                                          o.quad_max_depth);
            expected[ti * np + pi] = mass * double(o.samples);
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
        if (nc <= 400) {
            r.log += "cell (theta,phi): observed / expected\n";
            for (int ti = 0; ti < nt; ++ti) {
                for (int pi = 0; pi < np; ++pi) {
                    std::snprintf(buf, sizeof buf, "%6.0f/%-8.1f ", observed[ti * np + pi], expected[ti * np + pi]);
                    r.log += buf;
                }
                r.log += "\n";
            }
        } else {
            // A full table of a fine grid is unreadable: list the cells that contribute most instead.
            std::vector<int> worst(nc);
            for (int i = 0; i < nc; ++i) worst[i] = i;
            auto contrib = [&](int i) {
                double e = std::max(expected[i], 1e-9), d = observed[i] - expected[i];
                return d * d / e;
            };
            std::sort(worst.begin(), worst.end(), [&](int a, int b) { return contrib(a) > contrib(b); });
            r.log += "largest contributions: cell (theta bin, phi bin) observed / expected\n";
            for (int k = 0; k < std::min(nc, 30); ++k) {
                int i = worst[k];
                std::snprintf(buf, sizeof buf, "  (%3d,%3d) %8.0f / %-10.1f\n", i / np, i % np, observed[i],
                              expected[i]);
                r.log += buf;
            }
            std::snprintf(buf, sizeof buf, "pooled cells: observed %.0f / expected %.2f\n", pool_obs, pool_exp);
            r.log += buf;
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

// Integral of pdf over the sphere by adaptive quadrature on an n_theta x n_phi grid (uniform in
// cos theta and phi), for peaky densities that the fixed grid above misses or mis-weights.
inline double integrate_sphere_adaptive(const std::function<double(Vec3)>& pdf, int n_theta = 32, int n_phi = 64,
                                        double rel_tol = 1e-3, double abs_tol = 1e-5, int q = 3,
                                        int max_depth = 6) {
    double sum = 0;
    for (int i = 0; i < n_theta; ++i)
        for (int j = 0; j < n_phi; ++j)
            sum += integrate_patch(pdf, 1.0 - 2.0 * (i + 1) / n_theta, 1.0 - 2.0 * i / n_theta,
                                   2 * M_PI * j / n_phi, 2 * M_PI * (j + 1) / n_phi, q, rel_tol,
                                   abs_tol / (double(n_theta) * n_phi), max_depth);
    return sum;
}

// Integral of pdf over the sphere for a density with a sharp peak near `axis` (a glossy lobe around
// the mirror direction, a microfacet distribution around the normal). Cells are those of a (cos theta,
// phi) grid whose lines are uniform plus geometrically graded towards the axis's cos theta and phi
// (down to ~1e-7), so the peak is resolved whatever its width; z = 0 is always a grid line, so a
// density that stops at the horizon has no discontinuity inside a cell. Each cell is then refined
// adaptively (integrate_patch).
inline double integrate_sphere_peaked(const std::function<double(Vec3)>& pdf, Vec3 axis, int n_z = 12,
                                      int n_phi = 16, double rel_tol = 3e-3, double abs_tol = 1e-4, int q = 3,
                                      int max_depth = 5) {
    axis = normalize(axis);
    auto graded = [](double lo, double hi, double c, int n, bool periodic) {
        std::vector<double> v;
        for (int i = 0; i <= n; ++i) v.push_back(lo + (hi - lo) * i / n);
        for (double d = (hi - lo) / n; d > 1e-7; d *= 0.5)
            for (double x : {c - d, c + d}) {
                if (periodic) x = x - (hi - lo) * std::floor((x - lo) / (hi - lo));
                if (x > lo && x < hi) v.push_back(x);
            }
        if (c > lo && c < hi) v.push_back(c);
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end(), [](double a, double b) { return b - a < 1e-12; }), v.end());
        return v;
    };
    double phi_c = std::atan2(axis.y, axis.x);
    if (phi_c < 0) phi_c += 2 * M_PI;
    std::vector<double> zs = graded(-1.0, 1.0, axis.z, n_z, false);
    if (std::find(zs.begin(), zs.end(), 0.0) == zs.end()) {
        zs.push_back(0.0);
        std::sort(zs.begin(), zs.end());
    }
    const std::vector<double> ps = graded(0.0, 2 * M_PI, phi_c, n_phi, true);
    const double cell_tol = abs_tol / (double(zs.size()) * ps.size());
    double sum = 0;
    for (size_t i = 0; i + 1 < zs.size(); ++i)
        for (size_t j = 0; j + 1 < ps.size(); ++j)
            sum += integrate_patch(pdf, zs[i], zs[i + 1], ps[j], ps[j + 1], q, rel_tol, cell_tol, max_depth);
    return sum;
}

}  // namespace iris::test
