/* TEMPORARY STUB until the plot branch merges */
#include "vdbscatter/plot.h"
vdbs_status vdbs_plot_write_png(const char *path, const vdbs_plot_desc *desc, vdbs_error *err)
{
    (void)path; (void)desc; (void)err;
    return VDBS_OK;
}
