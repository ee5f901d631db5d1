/* `vsd export pov` in the library (pov_export.h): folders, frames, grids. */
#include "pov_export.h"
#include "df3.h"
#include "pov_file.h"
#include "pov_volume.h"
#include "vsd/vdbio.h"
#include <errno.h>
#include <float.h>
#include <math.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

vsd_status vsd_pov_prepare_dir(const char *outdir, char *err, size_t errlen)
{
    struct stat sb;
    if (!outdir || !outdir[0]) return vsd_fail(VSD_ERR_INVALID, err, errlen, "no output folder given");
    if (stat(outdir, &sb) != 0) {
        if (mkdir(outdir, 0777) != 0)
            return vsd_fail(VSD_ERR_IO, err, errlen, "%s: cannot create the output folder: %s", outdir,
                            strerror(errno));
        return VSD_OK;
    }
    if (!S_ISDIR(sb.st_mode)) return vsd_fail(VSD_ERR_IO, err, errlen, "%s: not a folder", outdir);
    if (access(outdir, W_OK | X_OK) != 0)
        return vsd_fail(VSD_ERR_IO, err, errlen, "%s: output folder not writable: %s", outdir, strerror(errno));
    return VSD_OK;
}

static int name_ok(const char *n)
{
    for (; *n; n++)
        if (!((*n >= 'a' && *n <= 'z') || (*n >= 'A' && *n <= 'Z') || (*n >= '0' && *n <= '9') || *n == '_' ||
              *n == '-' || *n == '.'))
            return 0;
    return 1;
}

static vsd_status write_grid(const vsd_volume *vol, const char *path, vsd_df3 *d, vsd_pov_export_report *rep,
                             char *err, size_t errlen)
{
    vsd_status st = vsd_df3_from_volume(vol, d, err, errlen);
    if (!st && (st = vsd_df3_write(path, d, err, errlen)) && rep) rep->output_error = 1;
    if (!st && rep) rep->negative_voxels += d->negative;
    return st;
}

vsd_status vsd_pov_export_frame(const vsd_scene *sc, int frame, const vsd_volume *density,
                                const vsd_volume *emission, const char *outdir, const char *name,
                                vsd_pov_export_report *rep, char *err, size_t errlen)
{
    char dfile[256], efile[256], path[1024];
    vsd_df3 d, e;
    vsd_pov_file pf;
    vsd_status st;
    memset(&d, 0, sizeof d);
    memset(&e, 0, sizeof e);
    if (!name || !name[0]) name = "vsd";
    if (!name_ok(name) || strlen(name) > 100)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "name '%s': use at most 100 of A-Z a-z 0-9 _ - .", name);
    /* names without folders: POV-Ray opens them relative to where it runs (outdir) */
    snprintf(dfile, sizeof dfile, "%s_density_%04d.df3", name, frame);
    snprintf(efile, sizeof efile, "%s_emission_%04d.df3", name, frame);
    snprintf(path, sizeof path, "%s/%s", outdir, dfile);
    st = write_grid(density, path, &d, rep, err, errlen);
    if (!st && emission) {
        snprintf(path, sizeof path, "%s/%s", outdir, efile);
        st = write_grid(emission, path, &e, rep, err, errlen);
    }
    if (!st) {
        snprintf(path, sizeof path, "%s/%s_%04d.inc", outdir, name, frame);
        st = vsd_pov_file_open(&pf, path, err, errlen);
        if (!st) {
            vsd_pov_write_volume(pf.f, sc, frame, &d, density, dfile, emission ? &e : NULL, emission, efile);
            st = vsd_pov_file_commit(&pf, err, errlen);
        }
        if (st && rep) rep->output_error = 1;
        if (!st && rep) {
            snprintf(rep->last_inc, sizeof rep->last_inc, "%s", path);
            rep->frames++;
        }
    }
    vsd_df3_free(&d);
    vsd_df3_free(&e);
    return st;
}

/* The grid the renderer would load for this frame (renderer.c's selection rules). */
static vsd_status load_grid(const char *file, const char *grid, int index, vsd_volume **out, char *err,
                            size_t errlen)
{
    vsd_grid_select sel;
    sel.name = grid && grid[0] ? grid : NULL;
    sel.index = index;
    return vsd_vdb_load(file, sel, out, err, errlen);
}

vsd_status vsd_pov_export(const vsd_scene *sc, const vsd_pov_export_options *opt, const char *outdir,
                          vsd_pov_export_report *rep, char *err, size_t errlen)
{
    const char *name = opt->name && opt->name[0] ? opt->name : "vsd";
    int want_emission = sc->volumes[0].emission_grid[0] && sc->volumes[0].medium.emission_strength > 0.0f;
    double lo_all[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi_all[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    double centre[3] = {0, 0, 0}, extent = 1, floor_z = 0;
    vsd_status st;
    int frame, a;
    memset(rep, 0, sizeof *rep);
    if (opt->last < opt->first)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "frames %d-%d: end before start", opt->first, opt->last);
    if ((st = vsd_pov_prepare_dir(outdir, err, errlen))) {
        rep->output_error = 1;
        return st;
    }
    for (frame = opt->first; frame <= opt->last; frame++) {
        char file[VSD_PATH_LEN];
        vsd_volume *dv = NULL, *ev = NULL;
        double lo[3], hi[3];
        if ((st = vsd_frame_path(sc->volumes[0].file, frame, file, sizeof file, err, errlen))) return st;
        st = load_grid(file, sc->volumes[0].grid, sc->volumes[0].grid_index, &dv, err, errlen);
        if (!st && want_emission) st = load_grid(file, sc->volumes[0].emission_grid, -1, &ev, err, errlen);
        if (!st) st = vsd_pov_export_frame(sc, frame, dv, ev, outdir, name, rep, err, errlen);
        if (!st) {
            vsd_volume_world_bounds(dv, sc->volumes[0].matrix, lo, hi);
            for (a = 0; a < 3; a++) {
                if (lo[a] < lo_all[a]) lo_all[a] = lo[a];
                if (hi[a] > hi_all[a]) hi_all[a] = hi[a];
            }
        }
        vsd_volume_destroy(dv);
        vsd_volume_destroy(ev);
        if (st) return st;
    }
    if (lo_all[0] <= hi_all[0]) {
        double e2 = 0;
        for (a = 0; a < 3; a++) {
            centre[a] = 0.5 * (lo_all[a] + hi_all[a]);
            e2 += (hi_all[a] - lo_all[a]) * (hi_all[a] - lo_all[a]);
        }
        extent = sqrt(e2);
        floor_z = lo_all[2];
    }
    st = vsd_pov_export_scene_files(sc, opt, floor_z, centre, extent, outdir, rep, err, errlen);
    if (st) rep->output_error = 1;
    return st;
}
