/* lbl_kernel.h — lbl's view pass through a refracting medium (§III-D with the view rays
 * bent by the same n field as the light; kernel/kernel_refract.h). Outside the index grid
 * a view ray is straight; inside it advances in steps of the field's integrator step,
 * each step's medium and records taken at its middle as the shared march does
 * (kernel_march.h, kernel_record_grid.h), until the light is gone or the ray leaves; an
 * opaque film's background is the map along the direction the ray leaves with (the visible
 * distortion). The records are the per-view baked ones (BAKED kind: the lights' term toward
 * the camera) plus records_ms. CPU only for now. A ray that bends for r->max_steps steps
 * stops there (what lies beyond is not marched). Emission outside the index grid (which
 * covers the density's box and a margin) is not marched either. */
#ifndef VSD_LBL_KERNEL_H
#define VSD_LBL_KERNEL_H
#include "kernel/kernel_record_grid.h"
#include "kernel/kernel_refract.h"

typedef struct VSD_ALIGN16 vsd_klbl_bent {
    vsd_krecord_grid g;           /* g.kd is the scene's */
    vsd_krefract r;
} vsd_klbl_bent;

VSD_DEVICE vsd_sample_result vsd_lbl_bent_pixel(const vsd_klbl_bent *b, int32_t px, int32_t py, float jx, float jy)
{
    const vsd_kernel_data *kd = b->g.kd;
    const vsd_krefract *r = &b->r;
    vsd_march_acc acc;
    vsd_records_corners corners;
    vsd_f3 o, d;
    float t0, t1, travelled = 0.0f;
    int32_t steps = 0;
    corners.filled = 0;
    corners.valid = 0;
    corners.key[0] = corners.key[1] = corners.key[2] = 0;
    vsd_march_begin(&acc);
    vsd_camera_ray(&kd->camera, px, py, jx, jy, &o, &d);
    {
        vsd_f3 g, v = f3s(0.0f);
        float h = r->step;
        int32_t inside = 0;
        while (steps < r->max_steps && acc.tr >= kd->march_stop) {
            if (!vsd_refract_inside(r, o)) {
                /* straight (n = 1) to the grid, a hair into it; again if rounding left o
                 * just outside; done when the ray misses it */
                if (!vsd_refract_clip(r, o, d, &t0, &t1)) break;
                t0 += 1e-3f * h;
                o = f3_madd(o, d, t0);
                travelled += t0;
                inside = 0;
                steps++;
                continue;
            }
            if (!inside) {
                v = f3_scale(d, vsd_refract_eval(r, o, &g));
                inside = 1;
            }
            {
                vsd_f3 p = f3_madd(o, d, 0.5f * h);
                float absorbed = vsd_march_medium(kd, &acc, p, h);
                if (absorbed > 0.0f) {
                    vsd_f3 ms, ss = vsd_records_inscatter(&b->g, p, 0, 0, &corners, &ms);
                    vsd_march_source(&acc, f3_mul(kd->medium.albedo, ss), f3_mul(kd->medium.albedo, ms),
                                     travelled + 0.5f * h, absorbed, absorbed);
                }
            }
            travelled += h;
            vsd_refract_step(r, &o, &v, &d, h);
            steps++;
        }
    }
    return vsd_march_finish(kd, &acc, d);
}

/* Stratum s of the n x n strata of pixel (x, y) (device/device_pass.h). */
VSD_STRATIFIED_SAMPLE(vsd_lbl_bent_sample, vsd_klbl_bent, vsd_lbl_bent_pixel)

#endif
