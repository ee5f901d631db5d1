/* Small integer helpers shared by the tile scheduler (a stride that visits every tile once)
 * and crm's residual hash (table sizes whose products are one-to-one). */
#ifndef VSD_COMMON_COPRIME_H
#define VSD_COMMON_COPRIME_H

static inline int vsd_gcd(int a, int b)
{
    while (b) {
        int t = a % b;
        a = b;
        b = t;
    }
    return a;
}

/* The smallest value >= r (and >= 1) coprime with m. Terminates: among m + 1 consecutive
 * integers there is one coprime with m. */
static inline int vsd_coprime_at_least(int r, int m)
{
    if (r < 1) r = 1;
    while (vsd_gcd(r, m) != 1) r++;
    return r;
}

#endif
