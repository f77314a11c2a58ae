#include "libguide/packed_map.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace iris::packed_map {

namespace {

// Cumulative counts out of kRowTotal for the non-negative masses m[0..n) (not all zero): every positive
// mass gets at least one count (it must stay reachable: its texels report a positive density), the rest
// are rounded, and the rounding's total error goes to the largest entry. Each entry's error is below
// one count, so the total is below n (at most n - 1), and the largest entry holds at least
// round(kRowTotal / n) counts, at least n for n <= 256: it keeps one count or more.
void cumulative_counts(const double* m, int n, uint16_t* end) {
    double total = 0;
    for (int i = 0; i < n; ++i) total += m[i];
    std::vector<int64_t> count(static_cast<size_t>(n));
    int64_t sum = 0;
    size_t largest = 0;
    for (size_t i = 0; i < size_t(n); ++i) {
        if (m[i] > 0) count[i] = std::max<int64_t>(1, std::llround(m[i] / total * kRowTotal));
        sum += count[i];
        if (count[i] > count[largest]) largest = i;
    }
    count[largest] += int64_t(kRowTotal) - sum;
    if (count[largest] < 1) throw std::logic_error("packed map: counts do not fit 16 bits");
    int64_t acc = 0;
    for (size_t i = 0; i < size_t(n); ++i) end[i] = static_cast<uint16_t>(acc += count[i]);
}

}  // namespace

void encode(const float* pdf, int R, unsigned char* map) {
    if (R < 1 || R > kMaxResolution)
        throw std::invalid_argument("packed map: resolution must be in [1, " + std::to_string(kMaxResolution) + "]");
    std::memset(map, 0, bytes(R));
    const size_t N = size_t(R) * size_t(R);
    bool any = false;
    for (size_t k = 0; k < N; ++k) any = any || pdf[k] > 0;
    std::vector<double> texel(static_cast<size_t>(R)), row(static_cast<size_t>(R), 0.0);
    for (int j = 0; j < R; ++j) {
        for (int i = 0; i < R; ++i) {
            const float p = pdf[size_t(j) * size_t(R) + size_t(i)];
            texel[size_t(i)] = !any ? 1.0 : p > 0 ? double(p) : 0.0;  // all zero: uniform, as SphereDistribution::build
            row[size_t(j)] += texel[size_t(i)];
        }
        uint16_t* ends = reinterpret_cast<uint16_t*>(map + row_end_bytes(R)) + size_t(j) * size_t(R);
        if (row[size_t(j)] > 0) cumulative_counts(texel.data(), R, ends);
    }
    cumulative_counts(row.data(), R, reinterpret_cast<uint16_t*>(map));
}

}  // namespace iris::packed_map
