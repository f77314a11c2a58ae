// The render stage's interface, for its command line and the tests: the camera path (path.h), the pilot
// (pilot.h) and the render loop with its options (render.h, render_options.h). The light paths are
// caustics.h and connections.h.
#pragma once

#include "tools/render/path.h"
#include "tools/render/pilot.h"
#include "tools/render/render.h"
#include "tools/render/render_options.h"
