// Internal to libcommon's BSDF code: the plugins that live beside bsdf.cpp (bsdf_phong.cpp,
// bsdf_mixture.cpp), called from its switch dispatch. Conventions as in bsdf.h; the *_front functions
// see the front side only (twosided already folded by the caller).
#pragma once

#include "libcommon/bsdf.h"

namespace iris::detail {

// Phong (Mitsuba 0.5's modified Phong, Lafortune & Willems 1994): f cos for wi.z > 0, wo.z > 0.
RGB phong_eval(const Bsdf& b, Vec3 wi, Vec3 wo);
float phong_pdf(const Bsdf& b, Vec3 wi, Vec3 wo);
// A direction from the cosine-power lobe only (bsdf.cpp picks the lobe with probability
// specular_sampling_weight, samples the diffuse part itself and fills pdf and weight from phong_pdf /
// phong_eval); false when the lobe sends it below the surface.
bool phong_sample_lobe(const Bsdf& b, Vec3 wi, Vec2 u, Vec3* wo);

// Mixture: the weighted sum of its parts (both sides; each part folds its own twosided).
RGB mixture_eval(const Bsdf& b, Vec3 wi, Vec3 wo, TransportMode mode);
float mixture_pdf(const Bsdf& b, Vec3 wi, Vec3 wo);
bool mixture_sample(const Bsdf& b, Vec3 wi, Vec2 u, float uc, BsdfSample* s, TransportMode mode);
float mixture_guidable_share(const Bsdf& b, Vec3 wi);
float mixture_guidable_pdf(const Bsdf& b, Vec3 wi, Vec3 wo);

}  // namespace iris::detail
