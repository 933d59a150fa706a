#include "engine/api/sinew.h"

extern "C" const char* sinew_version(void) {
#ifdef SINEW_DOUBLE
    return "0.1.0 (double)";
#else
    return "0.1.0 (float)";
#endif
}
