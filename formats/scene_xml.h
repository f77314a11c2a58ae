// Reader for the Mitsuba 0.5/0.6 scene XML subset iris supports (DESIGN.md section 3), with OBJ meshes.
// As Mitsuba does, a parameter no plugin reads is a warning naming file, line, plugin and parameter
// (Mitsuba's "Unqueried attribute"), and so is a plugin iris cannot build that nothing refers to; with
// SceneLoadOptions::strict an unread parameter is an error instead. Unknown plugins that a shape uses,
// malformed values and missing files are errors that name the file and line.
#pragma once

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "libcommon/scene.h"
#include "libcommon/spectrum.h"

namespace iris {

// Thrown for any problem with a scene file; what() is one line: "FILE:LINE: message".
struct SceneError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct SceneLoadOptions {
    // Values for $name parameters (<default name=... value=...> gives the fallback).
    std::map<std::string, std::string> parameters;
    // Receives one line per accepted-but-ignored parameter; null = print to stderr (unless quiet_warnings).
    std::vector<std::string>* warnings = nullptr;
    // With warnings null: print nothing. The tools' --no-scene-warnings: in a pipeline, the stages after
    // the first read the same scene, and repeating its warnings once per stage only buries them.
    bool quiet_warnings = false;
    // The tools' --strict: a parameter no plugin reads is an error, not a warning (a misspelt name then
    // cannot silently leave a default in place). Parameters on the documented ignore lists still warn.
    bool strict = false;
    // How a tabulated <spectrum value="l:v, ..."> is interpolated between its samples (and the CIE
    // tables with it): Linear, as the Mitsuba 0.6 core does, or Mitsuba050, the 0.5.0 release's
    // backwards interpolation inside each segment, with which the thesis's scenes were rendered
    // (libcommon/spectrum.h). The setting spectrum-interpolation (tools/common/settings.cpp).
    SpectrumInterpolation spectrum_interpolation = SpectrumInterpolation::Linear;
};

// Loads the scene, builds lights and the Embree BVH (Scene::finalize). Throws SceneError.
Scene load_scene(const std::string& path, const SceneLoadOptions& options = {});

// Everything load_scene does except Scene::finalize: reads and checks the XML and every mesh, fills
// the arrays, camera, film, render defaults, source and fingerprint. BSDF parameters are set but not
// prepared (bsdf_prepare runs in finalize). For tools and tests that need the description only.
Scene parse_scene(const std::string& path, const SceneLoadOptions& options = {});

}  // namespace iris
