/* Preloaded (LD_PRELOAD) in front of libOSMesa by tests/cli_files.cmake: OSMesa that cannot
   create a rendering context, as Mesa does when it runs out of memory (`ulimit -v`), so that a
   test can check what a replay with --render leaves behind then. */
#include <stddef.h>

void* OSMesaCreateContextExt(unsigned format, int depth_bits, int stencil_bits, int accum_bits, void* share) {
  (void)format;
  (void)depth_bits;
  (void)stencil_bits;
  (void)accum_bits;
  (void)share;
  return NULL;
}
