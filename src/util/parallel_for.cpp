#include "util/parallel_for.h"

#include <omp.h>

namespace facecap {

int DefaultNumThreads() { return omp_get_max_threads(); }

}  // namespace facecap
