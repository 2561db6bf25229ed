// Placeholder translation unit until the loader lands (keeps the library target non-empty).
#include "mjcf.hpp"
