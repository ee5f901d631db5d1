/* `vsd render --help`: the one place the job parser's users print its usage. Its own
 * file because it lists the methods from the registry (vsd_method_names), which links the
 * whole renderer; the light `vsd` front (service/front) parses jobs without it. */
#include "render_args.h"
#include "vsd/render.h"
#include <stdio.h>

void vsd_render_job_usage(FILE *f)
{
    const char *const *n = vsd_method_names();
    fprintf(f, "usage: vsd render SCENE.json|JOB.ini[Section] [options] [+switches]\n"
               "  --method NAME        render.method (%s", n[0]);
    for (n++; *n; n++) fprintf(f, ", %s", *n);
    fprintf(f, ")\n"
               "  --width N, --height N film size in pixels\n"
               "  --frames A-B | N     frame range (inclusive)\n"
               "  --samples N          samples per pixel\n"
               "  --seed N             random seed\n"
               "  --device auto|cpu|cuda\n"
               "  --threads N          CPU threads (default: all cores)\n"
               "  --output PATH        output.exr (#### = frame number), relative to the current folder\n"
               "  --preview PATH       also write a display PNG (#### = frame number)\n"
               "  --set KEY=VALUE      any scene field, e.g. --set medium.density=20\n"
               "  --continue           skip frames whose EXR is complete for this scene (POV-Ray's +C)\n"
               "  --remote[=ADDR]      render through a running `vsd serve` (default socket, a socket path,\n"
               "                       or HOST:PORT); uploads only the VDB frames and map it lacks\n"
               "  --token-file FILE    token for --remote=HOST:PORT (else $VSD_TOKEN)\n"
               "  --cache-dir DIR      where methods keep per-frame work between runs (crm's RBF fits;\n"
               "                       default $VSD_CACHE_DIR, else $XDG_CACHE_HOME/vsd or ~/.cache/vsd;\n"
               "                       'none' = no cache)\n"
               "  --max-voxels N       the most active voxels of the scene's density grids together,\n"
               "                       checked before loading (default 1e9)\n"
               "  --quiet              print nothing but errors\n"
               "POV-Ray INI files (Key=Value, [Section]) and switches +W +H +KFI +KFF +SF +EF +C +O +I +A +R\n"
               "+UA +FE +D +V are read as POV-Ray reads them (docs/pipeline.md). Command line over INI file\n"
               "over scene file.\n");
}

void vsd_render_job_print_usage(const vsd_render_job *job)
{
    if (job->help) vsd_render_job_usage(stdout);
    else if (job->usage_error) vsd_render_job_usage(stderr);
}
