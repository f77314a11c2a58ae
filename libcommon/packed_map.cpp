#include "libcommon/packed_map.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace iris::packed_map {

void encode(const float* pdf, int R, unsigned char* map) {
    const size_t N = size_t(R) * size_t(R);
    std::memset(map, 0, bytes(R));
    unsigned char* code = map + row_end_bytes(R);
    float max = 0;
    for (size_t k = 0; k < N; ++k) max = std::max(max, pdf[k]);
    for (size_t k = 0; k < N; ++k) {
        if (!(max > 0)) {
            code[k] = 255;  // all zero: uniform, as SphereDistribution::build
        } else if (pdf[k] > 0) {
            const double steps = std::round(kStepsPerOctave * std::log2(double(pdf[k]) / double(max)));
            code[k] = static_cast<unsigned char>(std::clamp(255.0 + steps, 1.0, 255.0));
        }
    }
    // Row probabilities from the values as the renderer sums them, in counts out of kRowTotal: every
    // row with a positive value gets at least one count (it must stay reachable: its texels report a
    // positive density), the rest are rounded, and the rounding's total error goes to the largest row.
    std::vector<double> mass(static_cast<size_t>(R));
    double total = 0;
    for (int j = 0; j < R; ++j) total += mass[size_t(j)] = row_sum(code + size_t(j) * size_t(R), R);
    std::vector<int64_t> count(static_cast<size_t>(R));
    int64_t sum = 0;
    size_t largest = 0;
    for (size_t j = 0; j < size_t(R); ++j) {
        if (mass[j] > 0) count[j] = std::max<int64_t>(1, std::llround(mass[j] / total * kRowTotal));
        sum += count[j];
        if (count[j] > count[largest]) largest = j;
    }
    // The largest row holds at least kRowTotal / R counts, more than the error (below R for R <= 256).
    count[largest] += int64_t(kRowTotal) - sum;
    if (count[largest] < 1) throw std::logic_error("packed map: row counts do not fit 16 bits");
    uint16_t* end = reinterpret_cast<uint16_t*>(map);
    int64_t acc = 0;
    for (size_t j = 0; j < size_t(R); ++j) end[j] = static_cast<uint16_t>(acc += count[j]);
}

}  // namespace iris::packed_map
