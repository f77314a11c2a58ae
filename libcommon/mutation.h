// Mutants: deliberate bugs that the test suite must catch (tests/mutants/README.md). Each is one line
// in the code, `if (IRIS_MUTANT(name)) ...;`, inactive unless the environment variable IRIS_MUTANT
// names it. The mutant tier (ctest -L mutant) runs a test with one mutant active and passes only when
// that test fails by an assertion: a negative control that runs, not a comment.
//
// Cost when inactive: the variable is read once per process (a function-local static); each check is
// then one load of a cached byte and a not-taken branch. An unknown name is a one-line error and exit 2
// at the first check (at startup: see mutation.cpp), so that a typo cannot make a mutant test pass.
#pragma once

#include <cstdint>

// The mutants, one X(name) each. Keep tests/mutants/README.md's table in step.
#define IRIS_MUTANT_LIST(X)   \
    X(cache_pdf_scale)        \
    X(mis_weight_one)         \
    X(nee_importance_mode)    \
    X(caustic_bias)           \
    X(mirrored_cache_map)     \
    X(max_depth_one_short)    \
    X(bsdf_alpha_off)         \
    X(light_pdf_scale)        \
    X(light_sample_pdf_scale) \
    X(cosine_warp_squeezed)   \
    X(spheremap_pdf_skew)     \
    X(photon_power_scale)     \
    X(product_pdf_scale)      \
    X(connection_weight_one)  \
    X(mask_shadow_rays_opaque) \
    X(mask_opacity_inverted)

namespace iris {

enum class Mutant : uint8_t {
    none = 0,
#define IRIS_MUTANT_ENUM(name) name,
    IRIS_MUTANT_LIST(IRIS_MUTANT_ENUM)
#undef IRIS_MUTANT_ENUM
};

// Reads IRIS_MUTANT (unset or empty: none); prints "iris: mutant NAME active" once per process tree.
Mutant read_mutant_from_environment();

inline Mutant active_mutant() {
    static const Mutant m = read_mutant_from_environment();
    return m;
}

}  // namespace iris

#define IRIS_MUTANT(name) (__builtin_expect(::iris::active_mutant() == ::iris::Mutant::name, 0))
