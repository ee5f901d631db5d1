/* One job's cancellation (cancel.h). The reason and the watched flag change together under
 * the lock, so a raise can never be lost between a step reading "not cancelled" and
 * handing its flag to a renderer: the watch sets the flag itself when the raise came first. */
#include "cancel.h"
#include <stdlib.h>

struct vsdd_cancel {
    vsdd_mutex lock;
    int reason;                    /* VSDD_CANCEL_* */
    volatile int *flag;            /* what the job runs now; NULL between its steps */
};

vsdd_cancel *vsdd_cancel_new(void)
{
    vsdd_cancel *x = calloc(1, sizeof *x);
    if (x) vsdd_mutex_init(&x->lock, VSDD_RANK_CANCEL);
    return x;
}

void vsdd_cancel_free(vsdd_cancel *x)
{
    if (!x) return;
    vsdd_mutex_destroy(&x->lock);
    free(x);
}

void vsdd_cancel_raise(vsdd_cancel *x, int reason)
{
    vsdd_lock(&x->lock);
    if (x->reason == VSDD_CANCEL_NONE) x->reason = reason;
    if (x->flag) *x->flag = 1;
    vsdd_unlock(&x->lock);
}

void vsdd_cancel_watch(vsdd_cancel *x, volatile int *flag)
{
    vsdd_lock(&x->lock);
    *flag = x->reason != VSDD_CANCEL_NONE;
    x->flag = flag;
    vsdd_unlock(&x->lock);
}

int vsdd_cancel_unwatch(vsdd_cancel *x)
{
    int reason;
    vsdd_lock(&x->lock);
    x->flag = NULL;
    reason = x->reason;
    vsdd_unlock(&x->lock);
    return reason;
}

int vsdd_cancel_reason(vsdd_cancel *x)
{
    int reason;
    vsdd_lock(&x->lock);
    reason = x->reason;
    vsdd_unlock(&x->lock);
    return reason;
}
