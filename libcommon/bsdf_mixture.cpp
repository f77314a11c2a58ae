// Mitsuba's `mixturebsdf` and `blendbsdf` as one type (BsdfType::Mixture): the value is the weighted
// sum of the parts' values; sampling picks one part with probability P_i = w_i / sum w (one-sample
// MIS over the parts, as Mitsuba does): a non-delta direction then gets the whole mixture's density
// sum_i P_i pdf_i(wo) and weight eval / pdf, so bsdf_pdf and bsdf_eval describe exactly what
// bsdf_sample does; a Dirac lobe keeps its discrete probability, P_i times the part's own.
//
// The lobe-choice number uc is laid out for path guiding (bsdf.h's contract: the replaceable lobes at
// uc >= 1 - share): first every part's non-replaceable share P_i (1 - g_i), then every part's replaceable
// share P_i g_i, each rescaled onto the part's own [0, 1 - g_i) or [1 - g_i, 1). A mixture of a mirror
// and a diffuse part thus behaves like plastic (a Dirac coat the cache leaves alone, a diffuse base it
// may replace), and a blend with rough glass lets a cache replace only its reflecting parts.
#include <algorithm>
#include <cmath>

#include "libcommon/bsdf_parts.h"

namespace iris {

float bsdf_part_probability(const Bsdf& b, int i) {
    float sum = 0;
    for (int j = 0; j < b.part_count; ++j) sum += b.part_weight[j];
    return sum > 0 ? b.part_weight[i] / sum : 0.0f;
}

void bsdf_link_parts(Bsdf& b, const Bsdf* const* parts) {
    b.mix_delta = b.part_count > 0;
    b.mix_has_delta = b.mix_transmits = false;
    for (int i = 0; i < b.part_count; ++i) {
        b.part[i] = parts[i];
        b.mix_delta = b.mix_delta && bsdf_is_delta(*parts[i]);
        b.mix_has_delta = b.mix_has_delta || bsdf_has_delta_lobe(*parts[i]);
        b.mix_transmits = b.mix_transmits || bsdf_transmits(*parts[i]);
    }
}

namespace detail {

RGB mixture_eval(const Bsdf& b, Vec3 wi, Vec3 wo, TransportMode mode) {
    RGB sum(0.0f);
    for (int i = 0; i < b.part_count; ++i)
        if (b.part_weight[i] > 0) sum += bsdf_eval(*b.part[i], wi, wo, mode) * b.part_weight[i];
    return sum;
}

float mixture_pdf(const Bsdf& b, Vec3 wi, Vec3 wo) {
    float sum = 0;
    for (int i = 0; i < b.part_count; ++i) {
        const float p = bsdf_part_probability(b, i);
        if (p > 0) sum += p * bsdf_pdf(*b.part[i], wi, wo);
    }
    return sum;
}

float mixture_guidable_share(const Bsdf& b, Vec3 wi) {
    float sum = 0;
    for (int i = 0; i < b.part_count; ++i) {
        const float p = bsdf_part_probability(b, i);
        if (p > 0) sum += p * bsdf_guidable_share(*b.part[i], wi);
    }
    return sum;
}

float mixture_guidable_pdf(const Bsdf& b, Vec3 wi, Vec3 wo) {
    float sum = 0;
    for (int i = 0; i < b.part_count; ++i) {
        const float p = bsdf_part_probability(b, i);
        if (p > 0) sum += p * bsdf_guidable_pdf(*b.part[i], wi, wo);
    }
    return sum;
}

bool mixture_sample(const Bsdf& b, Vec3 wi, Vec2 u, float uc, BsdfSample* s, TransportMode mode) {
    float prob[kMaxBsdfParts], share[kMaxBsdfParts];
    float low = 0;  // total probability of the parts' non-replaceable lobes: the start of the upper layout
    for (int i = 0; i < b.part_count; ++i) {
        prob[i] = bsdf_part_probability(b, i);
        share[i] = prob[i] > 0 ? bsdf_guidable_share(*b.part[i], wi) : 0.0f;
        low += prob[i] * (1 - share[i]);
    }
    const bool upper = uc >= low;
    float start = upper ? low : 0.0f;
    int chosen = -1;
    float uc_part = 0;
    for (int i = 0; i < b.part_count; ++i) {
        const float width = prob[i] * (upper ? share[i] : 1 - share[i]);
        if (!(width > 0)) continue;
        chosen = i;
        // The position within this part's interval, mapped onto the part's own lobe interval.
        const float t = std::clamp((uc - start) / width, 0.0f, 1.0f);
        uc_part = upper ? (1 - share[i]) + t * share[i] : t * (1 - share[i]);
        if (uc < start + width) break;  // (else the last interval with width keeps rounding leftovers)
        start += width;
    }
    if (chosen < 0) return false;
    // Keep the number inside the interval it was meant for (rounding at the ends).
    const float edge = 1 - share[chosen];
    uc_part = upper ? std::clamp(uc_part, edge, 0x1.fffffep-1f) : std::min(uc_part, std::nextafter(edge, 0.0f));
    if (!bsdf_sample(*b.part[chosen], wi, u, std::max(uc_part, 0.0f), s, mode)) return false;
    if (s->delta) {
        s->weight = s->weight * (b.part_weight[chosen] / prob[chosen]);
        s->pdf *= prob[chosen];
        return s->pdf > 0;
    }
    s->pdf = mixture_pdf(b, wi, s->wo);
    if (!(s->pdf > 0)) return false;
    s->weight = mixture_eval(b, wi, s->wo, mode) / s->pdf;
    return true;
}

}  // namespace detail
}  // namespace iris
