/* The public API (vdbscatter.h): commands run from their words, the option tables, dense
 * copies of a VDB's grids. */
#include "vdbscatter/vdbscatter.h"

#include <pthread.h>
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

/* The commands; vdbs_command_names lists them in this order. */
static const vdbs_command_spec *(*const commands[])(void) = {
    vdbs_command_bake,   vdbs_command_render,   vdbs_command_compare,   vdbs_command_info,
    vdbs_command_sample, vdbs_command_tradeoff, vdbs_command_phase_svd,
};
#define COMMAND_COUNT ((int)(sizeof commands / sizeof commands[0]))

static const vdbs_command_spec *find_command(const char *name)
{
    for (int i = 0; name && i < COMMAND_COUNT; ++i) {
        const vdbs_command_spec *spec = commands[i]();
        if (strcmp(spec->name, name) == 0)
            return spec;
    }
    return NULL;
}

/* What `vdbscatter --help` prints, and without a command `vdbscatter` alone (on stderr). */
static const char usage[] =
    "usage: vdbscatter COMMAND [options]\n"
    "\n"
    "commands:\n"
    "  bake IN.vdb -o OUT.vdb     light a density VDB and write a lit VDB\n"
    "  render IN.vdb -o IMG.exr   ray-march or path-trace a picture of a volume\n"
    "  compare A B                error metrics of image A against reference B\n"
    "  info FILE.vdb              list grids, sizes, value ranges, optical thickness\n"
    "  sample NAME -o OUT.vdb     write a procedural sample volume\n"
    "  tradeoff IN.vdb -o DIR     every method's error against time on your scene\n"
    "  phase-svd --g G --directions D   the phase matrix's factorisation error per term\n"
    "\n"
    "Run 'vdbscatter COMMAND --help' for the options of a command.\n"
    "Exit status: 0 success, 1 failure while working, 2 bad input or usage, 3 a frame\n"
    "sequence done in part (docs/sequences.md).\n";

/* The words before any command: none (the usage on stderr), --help, --version, or an unknown
 * command. Returns the exit status. */
static int run_top_level(const vdbs_command_desc *desc, vdbs_command_result *result)
{
    const char *word = desc->argc > 0 ? desc->argv[0] : NULL;
    if (!word) {
        vdbs_message_emit(VDBS_MESSAGE_NOTE, usage);
        snprintf(result->error, sizeof result->error, "no command given");
        result->status = VDBS_ERR_INPUT;
        return VDBS_EXIT_USAGE;
    }
    if (strcmp(word, "--help") == 0 || strcmp(word, "-h") == 0 || strcmp(word, "help") == 0) {
        vdbs_command_out("%s", usage);
        return VDBS_EXIT_OK;
    }
    if (strcmp(word, "--version") == 0) {
        vdbs_command_out("vdbscatter %s\n", VDBSCATTER_VERSION);
        return VDBS_EXIT_OK;
    }
    char message[256];
    snprintf(message, sizeof message, "unknown command '%.64s' (try --help)", word);
    vdbs_message_emitf(VDBS_MESSAGE_ERROR, "vdbscatter: %s\n", message);
    snprintf(result->error, sizeof result->error, "%s", message);
    result->status = VDBS_ERR_INPUT;
    return VDBS_EXIT_USAGE;
}

const char *vdbs_version(void)
{
    return VDBSCATTER_VERSION;
}

int vdbs_command_run(const vdbs_command_desc *desc, vdbs_command_result *result)
{
    memset(result, 0, sizeof *result);
    vdbs_command_context *context = NULL;
    if (!desc || desc->argc < 0 || (desc->argc > 0 && !desc->argv)) {
        snprintf(result->error, sizeof result->error, "no command words given");
        result->status = VDBS_ERR_INPUT;
        result->exit_status = VDBS_EXIT_USAGE;
    } else if (vdbs_command_context_begin(desc, result, &context) != VDBS_OK) {
        snprintf(result->error, sizeof result->error, "out of memory");
        result->status = VDBS_ERR_NOMEM;
        result->exit_status = VDBS_EXIT_FAILURE;
    } else {
        const vdbs_command_spec *command = desc->argc > 0 ? find_command(desc->argv[0]) : NULL;
        int status;
        if (command) {
            /* The commands read argv and never write it. */
            vdbs_options_args args;
            status = vdbs_command_open(command, desc->argc - 1, (char **)desc->argv + 1, &args);
            if (status == VDBS_COMMAND_CONTINUE &&
                (status = vdbs_command_run_options(command->name, &args)) == VDBS_EXIT_OK)
                status = command->run(&args);
        } else {
            status = run_top_level(desc, result);
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

static const char *command_names[COMMAND_COUNT + 1];

static void fill_command_names(void)
{
    for (int i = 0; i < COMMAND_COUNT; ++i)
        command_names[i] = commands[i]()->name;
}

const char *const *vdbs_command_names(void)
{
    static pthread_once_t once = PTHREAD_ONCE_INIT;
    pthread_once(&once, fill_command_names);
    return command_names;
}

int vdbs_command_option_count(const char *command)
{
    const vdbs_command_spec *c = find_command(command);
    if (!c)
        return -1;
    int n = 0;
    for (const vdbs_arg_option *o = c->options; o->name; ++o)
        ++n;
    return n;
}

vdbs_status vdbs_command_option_get(const char *command, int index, vdbs_arg_option *option)
{
    const int n = vdbs_command_option_count(command);
    if (!option || index < 0 || index >= n)
        return VDBS_ERR_INPUT;
    *option = find_command(command)->options[index];
    return VDBS_OK;
}

/* Channels of a grid type that dense copies take: 1, 3, or 0 for any other. */
static int dense_channels(const char *value_type)
{
    return strcmp(value_type, "float") == 0 ? 1 : strcmp(value_type, "vec3s") == 0 ? 3 : 0;
}

static int64_t dense_floats(const vdbs_dense_grid *g)
{
    return (int64_t)g->size[0] * g->size[1] * g->size[2] * g->channels;
}

/* The grid's name, channels, transform and active bounding box from its summary. */
static void dense_describe(const vdbio_grid_summary *s, vdbs_dense_grid *g)
{
    memset(g, 0, sizeof *g);
    snprintf(g->name, sizeof g->name, "%s", s->name);
    g->channels = dense_channels(s->value_type);
    memcpy(g->index_to_world, s->transform.m, sizeof g->index_to_world);
    for (int a = 0; a < 3; ++a) {
        g->origin[a] = s->bbox_min[a];
        g->size[a] = s->bbox_max[a] >= s->bbox_min[a] ? s->bbox_max[a] - s->bbox_min[a] + 1 : 0;
    }
}

/* Checks the copies against the limit, then fills them from one opening of the file. */
static vdbs_status dense_fill(const char *path, int64_t max_memory, vdbs_dense_grid *grids,
                              int count, vdbs_error *err)
{
    int64_t floats = 0;
    int largest = 0;
    for (int i = 0; i < count; ++i) {
        floats += dense_floats(&grids[i]);
        if (dense_floats(&grids[i]) > dense_floats(&grids[largest]))
            largest = i;
    }
    const int64_t limit = max_memory > 0    ? max_memory
                          : max_memory == 0 ? vdbs_memory_default_limit()
                                            : 0;
    if (limit > 0 && floats * (int64_t)sizeof(float) > limit) {
        const vdbs_dense_grid *g = &grids[largest];
        char need[32], cap[32];
        vdbs_memory_format(floats * (int64_t)sizeof(float), need, sizeof need);
        vdbs_memory_format(limit, cap, sizeof cap);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: the dense copies of %d grid%s need %s (the largest: '%s', "
                              "%d x %d x %d voxels) over the %s limit (%s)",
                              path, count, count == 1 ? "" : "s", need, g->name, g->size[0],
                              g->size[1], g->size[2], cap,
                              max_memory > 0 ? "max_memory" : VDBS_MEMORY_DEFAULT_SOURCE);
    }
    vdbs_status st;
    vdbio_lit *lit = NULL;
    if ((st = vdbio_lit_open(path, &lit, err)) != VDBS_OK)
        return st;
    for (int i = 0; i < count && st == VDBS_OK; ++i) {
        vdbs_dense_grid *g = &grids[i];
        if (dense_floats(g) == 0)
            continue;
        g->values = malloc((size_t)dense_floats(g) * sizeof(float));
        st = g->values ? vdbio_lit_dense(lit, g->name, g->origin, g->size, g->values, err)
                       : vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory for grid '%s'",
                                        path, g->name);
    }
    vdbio_lit_close(lit);
    return st;
}

vdbs_status vdbs_dense_read(const char *path, const char *name, int64_t max_memory,
                            vdbs_dense_grid *out, vdbs_error *err)
{
    memset(out, 0, sizeof *out);
    vdbio_grid_summary *summaries = NULL;
    int count = 0;
    vdbs_status st = vdbio_list_grids(path, &summaries, &count, err);
    if (st != VDBS_OK)
        return st;
    const vdbio_grid_summary *s = NULL;
    for (int i = 0; i < count && !s; ++i)
        if (!name || strcmp(summaries[i].name, name) == 0)
            s = &summaries[i];
    if (!s)
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "%s: no grid '%s'", path, name ? name : "");
    else if (!dense_channels(s->value_type))
        st = vdbs_error_set(err, VDBS_ERR_INPUT,
                            "%s: grid '%s' is of type %s (dense copies take float and vec3s)", path,
                            s->name, s->value_type);
    else
        dense_describe(s, out);
    free(summaries);
    if (st == VDBS_OK)
        st = dense_fill(path, max_memory, out, 1, err);
    if (st != VDBS_OK)
        vdbs_dense_free(out);
    return st;
}

vdbs_status vdbs_dense_read_all(const char *path, int64_t max_memory, vdbs_dense_grid **grids,
                                int *count, vdbs_error *err)
{
    *grids = NULL;
    *count = 0;
    vdbio_grid_summary *summaries = NULL;
    int n = 0;
    vdbs_status st = vdbio_list_grids(path, &summaries, &n, err);
    if (st != VDBS_OK)
        return st;
    vdbs_dense_grid *all = calloc(n > 0 ? (size_t)n : 1, sizeof *all);
    if (!all) {
        free(summaries);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory", path);
    }
    int kept = 0;
    for (int i = 0; i < n; ++i) {
        int seen = 0; /* the reader finds the first of two grids with one name */
        for (int k = 0; k < kept && !seen; ++k)
            seen = strcmp(all[k].name, summaries[i].name) == 0;
        if (!seen && dense_channels(summaries[i].value_type))
            dense_describe(&summaries[i], &all[kept++]);
    }
    free(summaries);
    if ((st = dense_fill(path, max_memory, all, kept, err)) != VDBS_OK) {
        vdbs_dense_free_all(all, kept);
        return st;
    }
    *grids = all;
    *count = kept;
    return VDBS_OK;
}

void vdbs_dense_free(vdbs_dense_grid *grid)
{
    if (!grid)
        return;
    free(grid->values);
    grid->values = NULL;
}

void vdbs_dense_free_all(vdbs_dense_grid *grids, int count)
{
    for (int i = 0; grids && i < count; ++i)
        vdbs_dense_free(&grids[i]);
    free(grids);
}
