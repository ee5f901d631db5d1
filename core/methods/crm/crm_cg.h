/* crm_cg.h — conjugate gradients on the normal equations A^T A x = A^T b (Zhou et al. 2008,
 * §5.4 "Conjugate Gradient Solver"), used by the multiple-scattering diffusion solve
 * (crm_diffusion.h) and usable for any small dense least-squares problem.
 *
 * The method is CGLS (Hestenes-Stiefel CG applied to A^T A): it runs exactly the CG
 * iterates of the normal equations but never forms A^T A, which would square the condition
 * number once more in rounding. Dense products go through OpenBLAS cblas (dgemm for the
 * k right-hand sides together, ddot/daxpy for the per-column scalars).
 * Nothing is owned across calls; work arrays are allocated per call (4 n k doubles). */
#ifndef VSD_CRM_CG_H
#define VSD_CRM_CG_H
#include <stddef.h>
#include "vsd/status.h"

/* Every this many iterations the recursively updated residual b - A x is recomputed from
 * x, so rounding drift cannot stall convergence on long runs. */
#define VSD_CRM_CG_RESTART_RESIDUAL 50

/* Solve min ||A x - b|| for k right-hand sides at once (each column has its own CG scalars).
 *   n          unknowns = equations (A is square, n x n, row-major); n = 0 is a no-op
 *   A          n * n, row-major
 *   b          n * k, row-major: b[i * k + c] is equation i of right-hand side c
 *   k          right-hand sides, >= 1 (e.g. 3 colour channels)
 *   x          n * k, same layout; in: the warm start (zeros for a cold start), out: solution
 *   tol        stop a column when its measure is <= tol (>= 0, finite). The measure is LSQR's
 *              pair of tests (Paige & Saunders 1982), the smaller of
 *                ||b - A x|| / ||b||                    (A x = b solved: consistent systems)
 *                ||A^T (b - A x)|| / (||A||_F ||b - A x||)  (residual orthogonal to A's range:
 *                                                          least squares, also inconsistent b);
 *              (both scale-free). The first bounds the relative error of x by cond(A)
 *              times it; the plain normal-equation residual ||A^T r|| / ||A^T b|| would
 *              bound it only by cond(A)^2 times it (that test stopped 1e6-conditioned
 *              diffusion systems with O(1) errors)
 *   max_iter   iteration bound (>= 0); each iteration costs two n x n x k dgemm
 *   iterations out (may be NULL): iterations run (the most of any column); == max_iter and
 *              residual > tol when the bound stopped it, which is not an error
 *   residual   out (may be NULL): the largest measure over the columns, recomputed from the
 *              returned x; 0 for columns with b = 0
 * A column with b = 0 gets x = 0 whatever the warm start (the minimum-norm solution).
 * From a cold start x = 0 the iterates converge to the minimum-norm least-squares solution
 * also when A is singular. Errors: VSD_ERR_INVALID for bad sizes, NULL arrays, a negative or
 * non-finite tol, max_iter < 0, non-finite entries of A, b or x (message names the entry),
 * or a non-finite iterate (a system too badly scaled for doubles); VSD_ERR_NOMEM. */
vsd_status vsd_crm_cg_normal(int n, const double *A, const double *b, int k, double *x, double tol,
                             int max_iter, int *iterations, double *residual, char *err, size_t errlen);

#endif
