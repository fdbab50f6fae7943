/* The accelerator registry (rt/accel.h): a new accelerator is its own file with one
 * static const AccelOps and one row here. */
#include "rt/accel.h"

#include <string.h>

extern const AccelOps accel_grid_ops;     /* grid_accel.c */
extern const AccelOps accel_twolevel_ops; /* twolevel.c */

/* Row order is the order of -h and of the "known accelerators" message. */
const AccelOps *const accel_registry[] = {
    &accel_none_ops,
    &accel_grid_ops,
    &accel_twolevel_ops,
    NULL,
};

const AccelOps *accel_find(const char *name)
{
    for (int i = 0; name && accel_registry[i]; i++)
        if (strcmp(accel_registry[i]->name, name) == 0)
            return accel_registry[i];
    return NULL;
}

const char *accel_names(void)
{
    static char names[256];
    if (!names[0]) {
        size_t len = 0;
        for (int i = 0; accel_registry[i]; i++) {
            const char *sep = i ? ", " : "";
            size_t add = strlen(sep) + strlen(accel_registry[i]->name);
            if (len + add + 1 > sizeof names)
                break;
            memcpy(names + len, sep, strlen(sep));
            memcpy(names + len + strlen(sep), accel_registry[i]->name, add - strlen(sep));
            len += add;
        }
        names[len] = '\0';
    }
    return names;
}

bool accel_init(Accel *a, const AccelOps *ops, const PrimTable *t, const AccelConfig *cfg,
                Diag *diag)
{
    a->ops = NULL;
    a->self = NULL;
    AccelConfig none;
    if (!cfg) {
        memset(&none, 0, sizeof none);
        cfg = &none;
    }
    void *self = ops->create(t, cfg, diag);
    if (!self)
        return false;
    a->ops = cfg->visualize && ops->visualize ? ops->visualize : ops;
    a->self = self;
    return true;
}

void accel_free(Accel *a)
{
    if (a->ops && a->ops->destroy)
        a->ops->destroy(a->self);
    a->ops = NULL;
    a->self = NULL;
}
