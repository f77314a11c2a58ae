#include "libcommon/progress.h"
