// IRIS_MUTANT: see mutation.h.
#include "libcommon/mutation.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace iris {

Mutant read_mutant_from_environment() {
    const char* v = std::getenv("IRIS_MUTANT");
    if (!v || !*v) return Mutant::none;
    static const struct {
        const char* name;
        Mutant m;
    } kNames[] = {
#define IRIS_MUTANT_NAME(n) {#n, Mutant::n},
        IRIS_MUTANT_LIST(IRIS_MUTANT_NAME)
#undef IRIS_MUTANT_NAME
    };
    for (const auto& e : kNames)
        if (std::strcmp(e.name, v) == 0) {
            // Once per process tree: the tools a test runs inherit the variable and stay quiet.
            if (!std::getenv("IRIS_MUTANT_ANNOUNCED")) {
                std::fprintf(stderr, "iris: mutant %s active\n", v);
                setenv("IRIS_MUTANT_ANNOUNCED", "1", 1);
            }
            return e.m;
        }
    std::fprintf(stderr, "iris: error: IRIS_MUTANT=%s names no mutant (libcommon/mutation.h lists them)\n", v);
    std::exit(2);
}

// Read at startup in every program that links a mutation hook: a misspelt name stops it at once, and a
// test binary announces the mutant even where only the tools it runs reach a hook.
[[maybe_unused]] static const Mutant kAtStartup = active_mutant();

}  // namespace iris
