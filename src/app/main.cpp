// facecap: one binary, a table of subcommands (app/commands.h).
#include <malloc.h>

#include "app/app.h"

int main(int argc, char** argv) {
#ifdef M_MMAP_THRESHOLD
  // Tensor buffers of a few MB are allocated and freed many times per training step. glibc's
  // default serves them with fresh mmaps and unmaps them on free, so every step zeroes and
  // faults in its pages again (14% of a blendshape training step). Keeping blocks up to 32 MB
  // (the largest threshold glibc accepts) in the heap, and not trimming it, reuses them.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
  return facecap::app::RunApp(argc, argv);
}
