// Test builders for phong and mixture BSDFs outside a scene: the parts of a mixture are prepared and kept
// at stable addresses (a mixture holds pointers to them, as Scene::finalize links them in a scene).
#pragma once

#include <deque>
#include <utility>
#include <vector>

#include "libcommon/bsdf.h"

namespace iris::test {

// Prepares `b` and keeps it for the whole test program; the pointer stays valid.
inline const Bsdf* keep(Bsdf b) {
    static std::deque<Bsdf> parts;  // a deque never moves its elements
    bsdf_prepare(b);
    parts.push_back(b);
    return &parts.back();
}

// Mitsuba's phong: diffuse reflectance kd, specular reflectance ks, exponent n.
inline Bsdf phong(RGB kd, RGB ks, float n) {
    Bsdf b;
    b.type = BsdfType::Phong;
    b.diffuse = kd;
    b.specular = ks;
    b.alpha_u = b.alpha_v = n;
    bsdf_prepare(b);
    return b;
}

// A mixture of (weight, part) pairs, prepared and linked.
inline Bsdf mix(std::vector<std::pair<float, Bsdf>> parts) {
    Bsdf m;
    m.type = BsdfType::Mixture;
    const Bsdf* p[kMaxBsdfParts];
    for (const auto& [w, b] : parts) {
        m.part_weight[m.part_count] = w;
        p[m.part_count++] = keep(b);
    }
    bsdf_prepare(m);
    bsdf_link_parts(m, p);
    return m;
}

}  // namespace iris::test
