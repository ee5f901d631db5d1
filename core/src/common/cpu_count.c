/* vsd_cpu_thread_count (cpu_count.h). */
#define _POSIX_C_SOURCE 200809L
#include "src/common/cpu_count.h"
#include <unistd.h>

int vsd_cpu_thread_count(int threads)
{
    long n = threads > 0 ? threads : sysconf(_SC_NPROCESSORS_ONLN);
    if (n < 1) n = 1;
    if (n > 256) n = 256;
    return (int)n;
}
