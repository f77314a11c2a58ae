#include "tools/render/integrator.h"
