/* Single scattering at the RBF centres in SH (Zhou et al. 2008, §5.3, appendix): the
 * optical-depth ZH table of a unit RBF, its per-centre rotation and accumulation, exp*,
 * the triple product with the lighting and the HG convolution. See crm_single.h for the
 * conventions. */
#define _POSIX_C_SOURCE 200809L   /* sysconf */
#include "crm_single.h"
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define PI 3.14159265358979323846
#define SQRT_PI 1.77245385090551602730
/* Gauss-Legendre nodes per table entry, over the cone the support subtends (or the whole
 * sphere inside it): the integrand is smooth in cos (the 3r cut leaves only a kink of size
 * exp(-9) at the cone edge); tests/test_crm_single.c finds the ZH within 1e-10 (inside)
 * to 1e-5 (a 0.4 degree cone, limited by its reference) of projections of Simpson line
 * integrals */
#define OD_QUAD 160
/* contributions to sigma * od below this SH norm are skipped: the reconstructed optical
 * depth they add is below ~1e-10 in every direction, so even 10^5 of them cannot matter */
#define SKIP_EPS 1e-10
#define MAX_THREADS 8

/* ---- the unit RBF's optical depth ------------------------------------------------------ */

double vsd_crm_od_theta(double q)
{
    const double s = (double)VSD_CRM_SUPPORT;
    if (!(q >= 0.0)) return PI;               /* NaN or negative: treat as the centre */
    if (q > s) return asin(s / q);
    return acos(q / s) + 0.5 * PI;
}

double vsd_crm_od_distance(double theta)
{
    const double s = (double)VSD_CRM_SUPPORT;
    if (theta <= 0.0) return HUGE_VAL;
    if (theta >= PI) return 0.0;
    /* asin(s/q) = theta for theta < pi/2; acos(q/s) = theta - pi/2 otherwise, and
     * cos(theta - pi/2) = sin(theta) */
    return theta < 0.5 * PI ? s / sin(theta) : s * sin(theta);
}

/* T_u along the ray from a point at distance q from the centre, at cosine z to the axis
 * towards the centre. On the ray x(t), |x - centre|^2 = (t - q z)^2 + b^2 with impact
 * parameter b^2 = q^2 (1 - z^2); inside the support s (|x| < 3) the chord is
 * |t - q z| < S = sqrt(9 - b^2), and the ray starts at t = 0, i.e. s = t - q z >= -q z:
 *   T = exp(-b^2) int_{max(-q z, -S)}^{S} exp(-s^2) ds. */
static double od_line(double q, double z)
{
    const double s2 = (double)VSD_CRM_SUPPORT * (double)VSD_CRM_SUPPORT;
    double b2 = q * q * (1.0 - z * z), S, lo;
    if (b2 >= s2) return 0.0;
    S = sqrt(s2 - b2);
    lo = -q * z;
    if (lo >= S) return 0.0;
    if (lo < -S) lo = -S;
    return exp(-b2) * 0.5 * SQRT_PI * (erf(S) - erf(lo));
}

void vsd_crm_od_zh_exact(int order, double q, double *zh)
{
    const double s = (double)VSD_CRM_SUPPORT;
    double x[OD_QUAD], w[OD_QUAD], z0 = -1.0;
    int i, l;
    for (l = 0; l < order; l++) zh[l] = 0.0;
    if (!(q < HUGE_VAL)) return;              /* infinitely far: nothing */
    /* outside the support T_u lives in the cone of half-angle asin(3/q) about the axis:
     * integrate over that cone only, so a far, narrow cone still gets every node */
    if (q > s) z0 = sqrt(1.0 - (s / q) * (s / q));
    vsd_sh_gauss_legendre(OD_QUAD, x, w);
    for (i = 0; i < OD_QUAD; i++) {
        double z = z0 + (x[i] + 1.0) * 0.5 * (1.0 - z0), wz = w[i] * 0.5 * (1.0 - z0);
        double d[3] = {sqrt(fmax(0.0, 1.0 - z * z)), 0.0, z}, y[VSD_SH_MAX_COEFFS];
        double v = od_line(q, z) * wz * 2.0 * PI;
        vsd_sh_eval(order, d, y);
        for (l = 0; l < order; l++) zh[l] += v * y[l * (l + 1)];
    }
}

vsd_status vsd_crm_od_table_create(int order, int angles, vsd_crm_od_table **out, char *err, size_t errlen)
{
    vsd_crm_od_table *t;
    vsd_status st;
    int k;
    if (!out) return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm optical-depth table: out is NULL");
    *out = NULL;
    if (order < 1 || order > VSD_SH_MAX_ORDER)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm optical-depth table: SH order %d out of range 1..%d",
                        order, VSD_SH_MAX_ORDER);
    if (angles < 16 || angles > 65536)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm optical-depth table: angles %d out of range 16..65536",
                        angles);
    t = calloc(1, sizeof *t);
    if (!t) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm optical-depth table: no memory");
    t->order = order;
    t->angles = angles;
    t->zh = malloc(sizeof(double) * (size_t)angles * (size_t)order);
    t->zh_far = malloc(sizeof(double) * (size_t)angles * (size_t)order);
    if (!t->zh || !t->zh_far) {
        vsd_crm_od_table_destroy(t);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm optical-depth table: no memory for %d entries", angles);
    }
    for (k = 0; k < angles; k++)
        vsd_crm_od_zh_exact(order, vsd_crm_od_distance(PI * k / (angles - 1)), t->zh + (size_t)k * order);
    /* zh / sin^2 tends to a constant as theta -> 0 (1/d^2 falloff): entry 0 takes entry 1's
     * value; entry angles-1 (theta = pi, sin = 0) is never read, the lookup there uses zh */
    for (k = 0; k < angles; k++) {
        int kk = k == 0 ? 1 : k, l;
        double s = sin(PI * kk / (angles - 1));
        for (l = 0; l < order; l++)
            t->zh_far[(size_t)k * order + l] = k == angles - 1 ? 0.0 : t->zh[(size_t)kk * order + l] / (s * s);
    }
    st = vsd_sh_tensor_create(order, &t->tensor, err, errlen);
    if (st == VSD_OK) st = vsd_sh_exp_table_create(order, &t->exp, err, errlen);
    if (st != VSD_OK) {
        vsd_crm_od_table_destroy(t);
        return st;
    }
    *out = t;
    return VSD_OK;
}

void vsd_crm_od_table_destroy(vsd_crm_od_table *t)
{
    if (!t) return;
    free(t->zh);
    free(t->zh_far);
    vsd_sh_tensor_destroy(t->tensor);
    vsd_sh_exp_table_destroy(t->exp);
    free(t);
}

void vsd_crm_od_lookup(const vsd_crm_od_table *t, double q, double *zh)
{
    int n = t->order, k, l;
    double theta = vsd_crm_od_theta(q), pos = theta / PI * (t->angles - 1), fr, s2 = 1.0;
    const double *tab = t->zh;
    k = (int)pos;
    if (k > t->angles - 2) k = t->angles - 2;
    fr = pos - k;
    if (theta < 0.5 * PI) {
        double s = (double)VSD_CRM_SUPPORT / q;   /* sin(theta) */
        tab = t->zh_far;
        s2 = s * s;
    }
    for (l = 0; l < n; l++) {
        double a = tab[(size_t)k * n + l], b = tab[(size_t)(k + 1) * n + l];
        zh[l] = (a + (b - a) * fr) * s2;
    }
}

/* ---- single scattering ------------------------------------------------------------------ */

/* Two passes over worker threads. Pass 1 walks the unordered pairs (l, h), l < h: both
 * directions of a pair share the distance and the axis up to sign, and the basis at the
 * axis (vsd_sh_eval, most of the cost) serves both since y_lm(-a) = (-1)^l y_lm(a); each
 * worker adds into its own slice of `acc` (no locks). Pass 2 sums the slices per centre
 * and does the per-centre SH work. */
typedef struct ss_shared {
    const vsd_crm_rbfs *rbfs;
    const vsd_crm_od_table *table;
    const double *env_sh;
    double sigma, albedo[3], hg[VSD_SH_MAX_ORDER];
    double *j_ss, *tau_out;
    double *acc;                /* [workers * count * order^2] optical-depth sums */
    int workers;
} ss_shared;

typedef struct ss_job {
    const ss_shared *s;
    int id;
    int row_begin, row_end;     /* pass 1: rows l of the pair triangle */
    int begin, end;             /* pass 2: centres */
    int pass;
} ss_job;

/* w r * (zh of T_u at q) into zh; 0 when sigma times its SH norm is negligible (the rotated
 * vector keeps the ZH's norm, since sum_m y_lm^2 = (2l+1)/4pi). */
static int scaled_depth(const ss_shared *s, double wr, double q, double *zh)
{
    int n = s->table->order, i;
    double norm2 = 0.0;
    if (wr == 0.0) return 0;
    vsd_crm_od_lookup(s->table, q, zh);
    for (i = 0; i < n; i++) {
        zh[i] *= wr;
        norm2 += zh[i] * zh[i];
    }
    return s->sigma * sqrt(norm2) >= SKIP_EPS;
}

/* One pair: B_h's depth seen from c_l (towards +a) and B_l's from c_h (towards -a). */
static void pair_depth(const ss_shared *s, double *acc, int l, int h)
{
    const vsd_crm_rbf *bl = s->rbfs->rbf + l, *bh = s->rbfs->rbf + h;
    const vsd_crm_od_table *t = s->table;
    int n = t->order, n2 = n * n, band, m, use_l, use_h;
    double *od_l = acc + (size_t)l * n2, *od_h = acc + (size_t)h * n2;
    double a[3], d, zh_h[VSD_SH_MAX_ORDER], zh_l[VSD_SH_MAX_ORDER], y[VSD_SH_MAX_COEFFS];
    double wr_l = (double)bl->w * bl->r, wr_h = (double)bh->w * bh->r;
    a[0] = (double)bh->c[0] - bl->c[0];
    a[1] = (double)bh->c[1] - bl->c[1];
    a[2] = (double)bh->c[2] - bl->c[2];
    d = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    if (d < 1e-9 * fmin(bl->r, bh->r)) {
        /* coincident centres: no axis, and the depth is isotropic to O(d / r) */
        double iso = t->zh[(size_t)(t->angles - 1) * n];
        od_l[0] += wr_h * iso;
        od_h[0] += wr_l * iso;
        return;
    }
    use_l = scaled_depth(s, wr_h, d / bh->r, zh_h);
    use_h = scaled_depth(s, wr_l, d / bl->r, zh_l);
    if (!use_l && !use_h) return;
    a[0] /= d; a[1] /= d; a[2] /= d;
    vsd_sh_eval(n, a, y);
    /* vsd_sh_zh_rotate's formula, f_lm = sqrt(4pi/(2l+1)) zh_l y_lm(axis), for both */
    for (band = 0; band < n; band++) {
        double k = sqrt(4.0 * PI / (2 * band + 1));
        double fl = use_l ? k * zh_h[band] : 0.0, fh = use_h ? k * zh_l[band] : 0.0;
        if (band & 1) fh = -fh;
        for (m = -band; m <= band; m++) {
            int i = band * (band + 1) + m;
            od_l[i] += fl * y[i];
            od_h[i] += fh * y[i];
        }
    }
}

static void pass_pairs(const ss_job *job)
{
    const ss_shared *s = job->s;
    int count = s->rbfs->count, l, h;
    double *acc = s->acc + (size_t)job->id * count * s->table->order * s->table->order;
    for (l = job->row_begin; l < job->row_end; l++)
        for (h = l + 1; h < count; h++) pair_depth(s, acc, l, h);
}

static void pass_centres(const ss_job *job)
{
    const ss_shared *s = job->s;
    const vsd_crm_od_table *t = s->table;
    int n = t->order, n2 = n * n, count = s->rbfs->count, l, c, band, m, i, w;
    /* the own RBF sees the same depth in every direction: half the line integral through
     * its centre, the table's last entry (theta = pi, d = 0) */
    double iso = t->zh[(size_t)(t->angles - 1) * n];
    for (l = job->begin; l < job->end; l++) {
        const vsd_crm_rbf *b = s->rbfs->rbf + l;
        double od[VSD_SH_MAX_COEFFS], tau[VSD_SH_MAX_COEFFS], prod[VSD_SH_MAX_COEFFS];
        double *j = s->j_ss + (size_t)l * 3 * n2;
        memset(od, 0, sizeof od);
        for (w = 0; w < s->workers; w++) {
            const double *a = s->acc + ((size_t)w * count + l) * n2;
            for (i = 0; i < n2; i++) od[i] += a[i];
        }
        od[0] += (double)b->w * b->r * iso;
        for (i = 0; i < n2; i++) od[i] *= -s->sigma;
        vsd_sh_exp(t->exp, od, tau);
        if (s->tau_out) memcpy(s->tau_out + (size_t)l * n2, tau, sizeof(double) * (size_t)n2);
        for (c = 0; c < 3; c++) {
            vsd_sh_triple(t->tensor, s->env_sh + (size_t)c * n2, tau, prod);
            vsd_sh_convolve_zh(n, prod, s->hg, prod);
            /* the convolution gives out(d) = int p(d . w_i) f(w_i) dw_i, and J_ss(w_o) needs
             * cos = (-w_i) . w_o, i.e. out(-w_o): y_lm(-w) = (-1)^l y_lm(w) */
            for (band = 0; band < n; band++) {
                double sc = (band & 1) ? -s->albedo[c] : s->albedo[c];
                for (m = -band; m <= band; m++) {
                    int idx = band * (band + 1) + m;
                    j[(size_t)c * n2 + idx] = sc * prod[idx];
                }
            }
        }
    }
}

static void *run_job(void *arg)
{
    const ss_job *job = arg;
    if (job->pass == 1) pass_pairs(job);
    else pass_centres(job);
    return NULL;
}

/* Job 0 runs on the caller; a thread that fails to start runs inline, so the result never
 * depends on thread creation succeeding. */
static void run_jobs(ss_job *jobs, int nt, int pass)
{
    pthread_t tid[MAX_THREADS];
    int started[MAX_THREADS] = {0}, i;
    for (i = 0; i < nt; i++) jobs[i].pass = pass;
    for (i = 1; i < nt; i++) started[i] = pthread_create(tid + i, NULL, run_job, jobs + i) == 0;
    run_job(jobs);
    for (i = 1; i < nt; i++) {
        if (started[i]) pthread_join(tid[i], NULL);
        else run_job(jobs + i);
    }
}

static int finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static vsd_status check_inputs(const vsd_crm_rbfs *rbfs, double sigma, const double albedo[3], double g,
                               int order, const double *env_sh, const vsd_crm_od_table *table,
                               const double *j_ss, char *err, size_t errlen)
{
    int i;
    const char *who = "crm single scattering";
    if (order < 1 || order > VSD_SH_MAX_ORDER)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: SH order %d out of range 1..%d", who, order,
                        VSD_SH_MAX_ORDER);
    if (!table) return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: optical-depth table is NULL", who);
    if (table->order != order)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: SH order %d does not match the table's order %d", who,
                        order, table->order);
    if (!rbfs) return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: rbfs is NULL", who);
    if (rbfs->count < 0 || (rbfs->count > 0 && !rbfs->rbf))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: rbfs has count %d and %s array", who, rbfs->count,
                        rbfs->rbf ? "an" : "no");
    if (!env_sh) return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: env_sh is NULL", who);
    if (!j_ss) return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: j_ss (output) is NULL", who);
    if (!albedo) return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: albedo is NULL", who);
    if (!(isfinite(sigma) && sigma >= 0.0))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: sigma_per_voxel %g must be finite and >= 0", who, sigma);
    for (i = 0; i < 3; i++)
        if (!(albedo[i] >= 0.0 && albedo[i] <= 1.0))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: albedo[%d] %g out of range 0..1", who, i, albedo[i]);
    if (!(g > -1.0 && g < 1.0))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: anisotropy g %g out of range (-1, 1)", who, g);
    for (i = 0; i < 3 * order * order; i++)
        if (!isfinite(env_sh[i]))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: env_sh[%d] is not finite", who, i);
    for (i = 0; i < rbfs->count; i++) {
        const vsd_crm_rbf *b = rbfs->rbf + i;
        if (!finite3(b->c) || !isfinite(b->w))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: RBF %d has a non-finite centre or weight", who, i);
        if (!(b->r > 0.0f && isfinite(b->r)))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: RBF %d radius %g must be finite and > 0", who, i,
                            (double)b->r);
    }
    return VSD_OK;
}

/* Threads: the online CPUs up to MAX_THREADS, and no more than one per 32 centres (the
 * work is count^2 pair lookups; below that a thread costs more than it saves). */
static int thread_count(int count)
{
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    int n = cpus > 0 ? (int)(cpus < MAX_THREADS ? cpus : MAX_THREADS) : 1;
    if (n > count / 32) n = count / 32;
    return n < 1 ? 1 : n;
}

vsd_status vsd_crm_single_scatter(const vsd_crm_rbfs *rbfs, double sigma_per_voxel, const double albedo[3],
                                  double g, int order, const double *env_sh, const vsd_crm_od_table *table,
                                  double *j_ss, double *transmittance_sh, char *err, size_t errlen)
{
    ss_shared s;
    ss_job jobs[MAX_THREADS];
    int nt, i, count, row;
    double pairs, done;
    vsd_status st = check_inputs(rbfs, sigma_per_voxel, albedo, g, order, env_sh, table, j_ss, err, errlen);
    if (st != VSD_OK) return st;
    count = rbfs->count;
    if (count == 0) return VSD_OK;
    nt = thread_count(count);
    memset(&s, 0, sizeof s);
    s.rbfs = rbfs;
    s.table = table;
    s.env_sh = env_sh;
    s.sigma = sigma_per_voxel;
    memcpy(s.albedo, albedo, sizeof s.albedo);
    vsd_sh_hg_zh(order, g, s.hg);
    s.j_ss = j_ss;
    s.tau_out = transmittance_sh;
    s.workers = nt;
    s.acc = calloc((size_t)nt * (size_t)count * (size_t)(order * order), sizeof(double));
    if (!s.acc)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm single scattering: no memory for %d x %d optical-depth "
                        "vectors", nt, count);
    /* pass 1 rows: row l holds count - 1 - l pairs, so cut the triangle into equal areas */
    pairs = 0.5 * (double)count * (count - 1);
    done = 0.0;
    row = 0;
    for (i = 0; i < nt; i++) {
        jobs[i].s = &s;
        jobs[i].id = i;
        jobs[i].row_begin = row;
        while (row < count && (i == nt - 1 || done < pairs * (i + 1) / nt)) {
            done += count - 1 - row;
            row++;
        }
        jobs[i].row_end = row;
        jobs[i].begin = (int)((long long)count * i / nt);
        jobs[i].end = (int)((long long)count * (i + 1) / nt);
    }
    run_jobs(jobs, nt, 1);
    run_jobs(jobs, nt, 2);
    free(s.acc);
    return VSD_OK;
}

void vsd_crm_eval_sh_rgb(int order, const double *sh, const double dir[3], double rgb[3])
{
    double y[VSD_SH_MAX_COEFFS];
    int n2 = order * order, c, i;
    vsd_sh_eval(order, dir, y);
    for (c = 0; c < 3; c++) {
        double s = 0.0;
        for (i = 0; i < n2; i++) s += sh[(size_t)c * n2 + i] * y[i];
        rgb[c] = s;
    }
}
