// Reader for the Mitsuba 0.5/0.6 scene XML subset iris supports (DESIGN.md section 3), with OBJ meshes.
// Every element and parameter must be understood: unknown plugins, misspelt or unused parameters and
// missing files are errors that name the file and line. A small documented set of parameters that have
// no effect in iris (sampler type, film banner, nearClip's siblings, Mitsuba integrator settings other
// than maxDepth/rrDepth, unreferenced media) is accepted with a warning, so that the thesis's scenes
// load unchanged.
#pragma once

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "libcommon/scene.h"

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
};

// Loads the scene, builds lights and the Embree BVH (Scene::finalize). Throws SceneError.
Scene load_scene(const std::string& path, const SceneLoadOptions& options = {});

// Everything load_scene does except Scene::finalize: reads and checks the XML and every mesh, fills
// the arrays, camera, film, render defaults, source and fingerprint. BSDF parameters are set but not
// prepared (bsdf_prepare runs in finalize). For tools and tests that need the description only.
Scene parse_scene(const std::string& path, const SceneLoadOptions& options = {});

}  // namespace iris
