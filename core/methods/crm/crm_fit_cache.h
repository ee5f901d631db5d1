/* crm_fit_cache.h — the RBF fit of a frame (crm_fit.h) kept on disk, one file per fit,
 * named by a hash of everything the fit depends on, so a re-render skips the minimisation.
 *
 * File <dir>/<key>.crmfit, little-endian:
 *   "VSDCRMFT" | u32 version (1) | u32 count | key, 64 bytes NUL-padded | f64 rel_error |
 *   count x (f32 c0, c1, c2, r, w) | u64 XXH3-64 of all bytes before it.
 * Written to a temporary name and renamed, so readers never see half a file. */
#ifndef VSD_CRM_FIT_CACHE_H
#define VSD_CRM_FIT_CACHE_H
#include "crm_fit.h"

#define VSD_CRM_FIT_CACHE_VERSION 1

/* key: 32 lowercase hex digits (XXH3-128) + NUL, in a buffer of 65. It covers the grid's
 * dimensions and bytes, the fit options (fit_stride resolved), a version of the fit
 * algorithm, and for a coherent frame (previous with RBFs) the previous RBFs and
 * first_rel_error (the insertion rule depends on it); first_rel_error is ignored otherwise. */
vsd_status vsd_crm_fit_cache_key(const vsd_crm_dense *d, const vsd_crm_fit_options *o,
                                 const vsd_crm_rbfs *previous, double first_rel_error, char key[65]);

/* VSD_ERR_NOT_FOUND: no file for key. VSD_ERR_FORMAT: a file that is truncated, foreign,
 * corrupt, of another version or of another key. VSD_ERR_IO: unreadable. On success `out`
 * owns a new array (vsd_crm_rbfs_free); on failure it is empty. rel_error may be NULL. */
vsd_status vsd_crm_fit_cache_load(const char *dir, const char *key, vsd_crm_rbfs *out, double *rel_error,
                                  char *err, size_t errlen);

/* Creates dir (and its parents) when needed; replaces an existing file atomically. */
vsd_status vsd_crm_fit_cache_save(const char *dir, const char *key, const vsd_crm_rbfs *r, double rel_error,
                                  char *err, size_t errlen);

/* Loads the fit from dir, or fits (vsd_crm_fit) and saves it; dir == NULL: no cache. A file
 * that does not load (corrupt, truncated, other version) is refitted and overwritten. On a
 * hit *was_cached = 1 and stats has only rbf_count, rel_error and seconds (evaluations 0).
 * When the fit succeeded but saving it failed, returns VSD_ERR_IO with `out` holding the
 * fit, so a caller may warn and go on. was_cached and stats may be NULL. */
vsd_status vsd_crm_fit_cached(const char *dir, const vsd_crm_dense *d, const vsd_crm_fit_options *o,
                              const vsd_crm_rbfs *previous, double first_rel_error, vsd_crm_rbfs *out,
                              vsd_crm_fit_stats *stats, char *err, size_t errlen, int *was_cached);

#endif
