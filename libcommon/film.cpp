#include "libcommon/film.h"
