/* The public API (vdbscatter.h): commands run from their words, the option tables, dense
 * copies of a VDB's grids. */
#include "vdbscatter/vdbscatter.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "context.h"
#include "vdbscatter/memory.h"
#include "vdbscatter/message.h"
#include "vdbscatter/vdbio.h"

#ifndef VDBSCATTER_VERSION
#define VDBSCATTER_VERSION "0"
#endif

typedef struct command_entry {
    const char *name;
    int (*run)(int argc, char **argv);
    const vdbs_arg_option *(*options)(void);
} command_entry;

static const command_entry commands[] = {
    {"bake", vdbs_command_bake, vdbs_command_bake_options},
    {"render", vdbs_command_render, vdbs_command_render_options},
    {"compare", vdbs_command_compare, vdbs_command_compare_options},
    {"info", vdbs_command_info, vdbs_command_info_options},
    {"sample", vdbs_command_sample, vdbs_command_sample_options},
    {"tradeoff", vdbs_command_tradeoff, vdbs_command_tradeoff_options},
    {"phase-svd", vdbs_command_phase_svd, vdbs_command_phase_svd_options},
};
#define COMMAND_COUNT ((int)(sizeof commands / sizeof commands[0]))

static const command_entry *find_command(const char *name)
{
    for (int i = 0; name && i < COMMAND_COUNT; ++i)
        if (strcmp(commands[i].name, name) == 0)
            return &commands[i];
    return NULL;
}

const char *vdbs_version(void)
{
    return VDBSCATTER_VERSION;
}

int vdbs_command_run(const vdbs_command_desc *desc, vdbs_command_result *result)
{
    memset(result, 0, sizeof *result);
    vdbs_command_context *context = NULL;
    if (!desc || desc->argc < 1 || !desc->argv || !desc->argv[0]) {
        snprintf(result->error, sizeof result->error, "no command given");
        result->status = VDBS_ERR_INPUT;
        result->exit_status = VDBS_EXIT_USAGE;
    } else if (vdbs_command_context_begin(desc, result, &context) != VDBS_OK) {
        snprintf(result->error, sizeof result->error, "out of memory");
        result->status = VDBS_ERR_NOMEM;
        result->exit_status = VDBS_EXIT_FAILURE;
    } else {
        const command_entry *command = find_command(desc->argv[0]);
        int status;
        if (command) {
            /* The commands read argv and never write it. */
            status = command->run(desc->argc - 1, (char **)desc->argv + 1);
        } else {
            char message[256];
            snprintf(message, sizeof message, "unknown command '%.64s' (try --help)",
                     desc->argv[0]);
            vdbs_message_emitf(VDBS_MESSAGE_ERROR, "vdbscatter: %s\n", message);
            snprintf(result->error, sizeof result->error, "%s", message);
            result->status = VDBS_ERR_INPUT;
            status = VDBS_EXIT_USAGE;
        }
        if (status == VDBS_EXIT_OK)
            result->status = VDBS_OK;
        else if (result->status == VDBS_OK) /* failed without saying why */
            result->status = status == VDBS_EXIT_USAGE ? VDBS_ERR_INPUT : VDBS_ERR_INTERNAL;
        vdbs_command_context_end(context, status);
    }
    if (!result->output) /* never NULL for the caller */
        result->output = calloc(1, 1);
    return result->exit_status;
}

void vdbs_command_result_free(vdbs_command_result *result)
{
    if (!result)
        return;
    free(result->output);
    free(result->rgb);
    free(result->se);
    result->output = NULL;
    result->rgb = result->se = NULL;
}

const char *const *vdbs_command_names(void)
{
    static const char *const names[] = {"bake",   "render",   "compare",   "info",
                                        "sample", "tradeoff", "phase-svd", NULL};
    return names;
}

int vdbs_command_option_count(const char *command)
{
    const command_entry *c = find_command(command);
    if (!c)
        return -1;
    int n = 0;
    for (const vdbs_arg_option *o = c->options(); o->name; ++o)
        ++n;
    return n;
}

vdbs_status vdbs_command_option_get(const char *command, int index, vdbs_arg_option *option)
{
    const int n = vdbs_command_option_count(command);
    if (!option || index < 0 || index >= n)
        return VDBS_ERR_INPUT;
    *option = find_command(command)->options()[index];
    return VDBS_OK;
}

/* Reads the dense copy voxel by voxel through the lit reader's cached accessors. */
static vdbs_status copy_dense(const char *path, const vdbio_lit *lit, vdbs_dense_grid *out,
                              vdbs_error *err)
{
    const int nx = out->size[0], ny = out->size[1], nz = out->size[2];
    vdbs_status failed = VDBS_OK;
#pragma omp parallel for schedule(dynamic, 1)
    for (int z = 0; z < nz; ++z) {
        vdbs_error inner;
        for (int y = 0; y < ny && failed == VDBS_OK; ++y)
            for (int x = 0; x < nx; ++x) {
                const int ijk[3] = {out->origin[0] + x, out->origin[1] + y, out->origin[2] + z};
                float *v = out->values + (((size_t)z * ny + y) * nx + x) * (size_t)out->channels;
                vdbs_status st = out->channels == 3
                                     ? vdbio_lit_vec3(lit, out->name, ijk, v, &inner)
                                     : vdbio_lit_float(lit, out->name, ijk, v, &inner);
                if (st != VDBS_OK) {
#pragma omp critical(vdbs_dense_error)
                    if (failed == VDBS_OK) {
                        failed = st;
                        vdbs_error_set(err, st, "%s: grid '%s': %s", path, out->name,
                                       inner.message);
                    }
                    break;
                }
            }
    }
    return failed;
}

vdbs_status vdbs_dense_read(const char *path, const char *name, int64_t max_memory,
                            vdbs_dense_grid *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    vdbio_grid_summary *grids = NULL;
    int count = 0;
    vdbs_status st = vdbio_list_grids(path, &grids, &count, err);
    if (st != VDBS_OK)
        return st;
    const vdbio_grid_summary *g = NULL;
    for (int i = 0; i < count && !g; ++i)
        if (!name || strcmp(grids[i].name, name) == 0)
            g = &grids[i];
    if (!g) {
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "%s: no grid '%s'", path, name ? name : "");
        free(grids);
        return st;
    }
    if (strcmp(g->value_type, "float") == 0)
        out->channels = 1;
    else if (strcmp(g->value_type, "vec3s") == 0)
        out->channels = 3;
    else {
        st = vdbs_error_set(err, VDBS_ERR_INPUT,
                            "%s: grid '%s' is of type %s (dense copies take float and vec3s)", path,
                            g->name, g->value_type);
        free(grids);
        return st;
    }
    snprintf(out->name, sizeof out->name, "%s", g->name);
    memcpy(out->index_to_world, g->transform.m, sizeof out->index_to_world);
    int64_t voxels = 1;
    for (int a = 0; a < 3; ++a) {
        out->origin[a] = g->bbox_min[a];
        out->size[a] = g->bbox_max[a] >= g->bbox_min[a] ? g->bbox_max[a] - g->bbox_min[a] + 1 : 0;
        voxels *= out->size[a];
    }
    free(grids);
    if (voxels == 0)
        return VDBS_OK;
    vdbs_memory_estimate estimate = {0};
    vdbs_memory_add(&estimate, "dense copy", voxels * out->channels * (int64_t)sizeof(float));
    const int64_t limit = max_memory > 0    ? max_memory
                          : max_memory == 0 ? vdbs_memory_default_limit()
                                            : 0;
    char what[320];
    snprintf(what, sizeof what, "grid '%.200s', %d x %d x %d voxels", out->name, out->size[0],
             out->size[1], out->size[2]);
    if ((st = vdbs_memory_check(&estimate, limit,
                                max_memory > 0 ? "max_memory" : VDBS_MEMORY_DEFAULT_SOURCE, what,
                                "max_memory", err)) != VDBS_OK)
        return st;
    out->values = malloc((size_t)voxels * (size_t)out->channels * sizeof(float));
    if (!out->values)
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory for %s", path, what);
    vdbio_lit *lit = NULL;
    if ((st = vdbio_lit_open(path, &lit, err)) == VDBS_OK) {
        st = copy_dense(path, lit, out, err);
        vdbio_lit_close(lit);
    }
    if (st != VDBS_OK)
        vdbs_dense_free(out);
    return st;
}

void vdbs_dense_free(vdbs_dense_grid *grid)
{
    if (!grid)
        return;
    free(grid->values);
    grid->values = NULL;
}
