/* cpu_count.h — how many threads a request for `threads` (0 = one per online CPU) gets:
 * the render's CPU pool and the EXR writer's chunk encoders share the rule. */
#ifndef VSD_COMMON_CPU_COUNT_H
#define VSD_COMMON_CPU_COUNT_H
int vsd_cpu_thread_count(int threads);
#endif
