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

/* A volume's df3 file name, without folder: POV-Ray opens it relative to where it runs
 * (outdir). A scene of several volumes puts the volume's index in it. */
static void df3_name(char *buf, size_t len, const char *name, int count, int index, const char *what, int frame)
{
    if (count > 1)
        snprintf(buf, len, "%s_v%d_%s_%04d.df3", name, index, what, frame);
    else
        snprintf(buf, len, "%s_%s_%04d.df3", name, what, frame);
}

/* volumes[0 .. count-1] of one frame. Each df3's voxels are freed once written: the .inc
 * needs only their size, placement and scale. */
static vsd_status export_frame(const vsd_scene *sc, int count, int frame, const vsd_volume *const *density,
                               const vsd_volume *const *emission, const char *outdir, const char *name,
                               vsd_pov_export_report *rep, char *err, size_t errlen)
{
    char dfile[VSD_MAX_VOLUMES][256], efile[VSD_MAX_VOLUMES][256], path[1024];
    vsd_df3 d[VSD_MAX_VOLUMES], e[VSD_MAX_VOLUMES];
    vsd_pov_volume_part parts[VSD_MAX_VOLUMES];
    vsd_pov_file pf;
    vsd_status st = VSD_OK;
    int i;
    memset(d, 0, sizeof d);
    memset(e, 0, sizeof e);
    if (!name || !name[0]) name = "vsd";
    if (!name_ok(name) || strlen(name) > 100)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "name '%s': use at most 100 of A-Z a-z 0-9 _ - .", name);
    if (count < 1 || count > VSD_MAX_VOLUMES)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%d volumes: 1 to %d can be exported", count, VSD_MAX_VOLUMES);
    for (i = 0; i < count && !st; i++) {
        if (!density[i]) {
            st = vsd_fail(VSD_ERR_INVALID, err, errlen, "volumes[%d]: no density grid given", i);
            break;
        }
        df3_name(dfile[i], sizeof dfile[i], name, count, i, "density", frame);
        df3_name(efile[i], sizeof efile[i], name, count, i, "emission", frame);
        snprintf(path, sizeof path, "%s/%s", outdir, dfile[i]);
        st = write_grid(density[i], path, &d[i], rep, err, errlen);
        vsd_df3_free(&d[i]);
        if (!st && emission && emission[i]) {
            snprintf(path, sizeof path, "%s/%s", outdir, efile[i]);
            st = write_grid(emission[i], path, &e[i], rep, err, errlen);
            vsd_df3_free(&e[i]);
        }
        parts[i].index = i;
        parts[i].volume = &sc->volumes[i];
        parts[i].density = &d[i];
        parts[i].density_grid = density[i];
        parts[i].density_df3 = dfile[i];
        parts[i].emission = emission && emission[i] ? &e[i] : NULL;
        parts[i].emission_grid = emission ? emission[i] : NULL;
        parts[i].emission_df3 = efile[i];
    }
    if (!st) {
        snprintf(path, sizeof path, "%s/%s_%04d.inc", outdir, name, frame);
        st = vsd_pov_file_open(&pf, path, err, errlen);
        if (!st) {
            vsd_pov_write_volumes(pf.f, frame, parts, count);
            st = vsd_pov_file_commit(&pf, err, errlen);
        }
        if (st && rep) rep->output_error = 1;
        if (!st && rep) {
            snprintf(rep->last_inc, sizeof rep->last_inc, "%s", path);
            rep->frames++;
        }
    }
    for (i = 0; i < count; i++) {
        vsd_df3_free(&d[i]);
        vsd_df3_free(&e[i]);
    }
    return st;
}

vsd_status vsd_pov_export_frame_volumes(const vsd_scene *sc, int frame, const vsd_volume *const *density,
                                        const vsd_volume *const *emission, const char *outdir, const char *name,
                                        vsd_pov_export_report *rep, char *err, size_t errlen)
{
    return export_frame(sc, sc->volume_count, frame, density, emission, outdir, name, rep, err, errlen);
}

vsd_status vsd_pov_export_frame(const vsd_scene *sc, int frame, const vsd_volume *density,
                                const vsd_volume *emission, const char *outdir, const char *name,
                                vsd_pov_export_report *rep, char *err, size_t errlen)
{
    return export_frame(sc, 1, frame, &density, &emission, outdir, name, rep, err, errlen);
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

/* In a scene of several volumes, an error about one names it: "volumes[I] (FILE): ...",
 * dropping the loader's own leading "FILE: ". */
static void name_volume(int index, const char *file, char *err, size_t errlen)
{
    char msg[1024];
    const char *m = err;
    size_t fl = strlen(file);
    if (!err || !errlen) return;
    if (strncmp(m, file, fl) == 0 && m[fl] == ':' && m[fl + 1] == ' ') m += fl + 2;
    snprintf(msg, sizeof msg, "%s", m);
    snprintf(err, errlen, "volumes[%d] (%s): %s", index, file, msg);
}

/* Frame `frame` of every volume: the grids into dv[i], ev[i] (ev[i] NULL without
 * emission). On an error the caller still destroys what was loaded. */
static vsd_status load_frame(const vsd_scene *sc, int frame, vsd_volume **dv, vsd_volume **ev, char *err,
                             size_t errlen)
{
    int i;
    for (i = 0; i < sc->volume_count; i++) {
        const vsd_scene_volume *v = &sc->volumes[i];
        char file[VSD_PATH_LEN];
        vsd_status st = vsd_frame_path(v->file, vsd_scene_volume_frame(v, frame), file, sizeof file, err, errlen);
        if (st) snprintf(file, sizeof file, "%s", v->file);
        if (!st) st = load_grid(file, v->grid, v->grid_index, &dv[i], err, errlen);
        if (!st && v->emission_grid[0] && v->medium.emission_strength > 0.0f)
            st = load_grid(file, v->emission_grid, -1, &ev[i], err, errlen);
        if (st) {
            if (sc->volume_count > 1) name_volume(i, file, err, errlen);
            return st;
        }
    }
    return VSD_OK;
}

vsd_status vsd_pov_export(const vsd_scene *sc, const vsd_pov_export_options *opt, const char *outdir,
                          vsd_pov_export_report *rep, char *err, size_t errlen)
{
    const char *name = opt->name && opt->name[0] ? opt->name : "vsd";
    double lo_all[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi_all[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    double centre[3] = {0, 0, 0}, extent = 1, floor_z = 0;
    vsd_status st;
    int frame, a, i;
    memset(rep, 0, sizeof *rep);
    if (sc->volume_count < 1 || sc->volume_count > VSD_MAX_VOLUMES)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%d volumes: 1 to %d can be exported", sc->volume_count,
                        VSD_MAX_VOLUMES);
    if (opt->last < opt->first)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "frames %d-%d: end before start", opt->first, opt->last);
    if ((st = vsd_pov_prepare_dir(outdir, err, errlen))) {
        rep->output_error = 1;
        return st;
    }
    for (frame = opt->first; frame <= opt->last; frame++) {
        vsd_volume *dv[VSD_MAX_VOLUMES] = {0}, *ev[VSD_MAX_VOLUMES] = {0};
        st = load_frame(sc, frame, dv, ev, err, errlen);
        if (!st)
            st = vsd_pov_export_frame_volumes(sc, frame, (const vsd_volume *const *)dv,
                                              (const vsd_volume *const *)ev, outdir, name, rep, err, errlen);
        for (i = 0; i < sc->volume_count; i++) {
            double lo[3], hi[3];
            if (!st) {
                vsd_volume_world_bounds(dv[i], sc->volumes[i].matrix, lo, hi);
                for (a = 0; a < 3; a++) {
                    if (lo[a] < lo_all[a]) lo_all[a] = lo[a];
                    if (hi[a] > hi_all[a]) hi_all[a] = hi[a];
                }
            }
            vsd_volume_destroy(dv[i]);
            vsd_volume_destroy(ev[i]);
        }
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
