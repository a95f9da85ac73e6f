#include "solver_flags.h"

#include <stdlib.h>
#include <string.h>

#include "vdbscatter/solver.h"

int cli_solver_flags_add(cli_option *options, int count, int max)
{
    const vdbs_solver *s;
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m)
        for (int i = 0; i < s->option_count && count + 1 < max; ++i)
            options[count++] =
                (cli_option){s->options[i].flag, s->options[i].syntax ? CLI_VALUE : CLI_FLAG};
    options[count] = (cli_option){NULL, CLI_FLAG};
    return count;
}

vdbs_status cli_solver_flag(const char *name, const char *value, vdbs_scene *scene, int *handled,
                            vdbs_error *err)
{
    const vdbs_solver_option *o = vdbs_solver_option_by_flag(name, NULL);
    *handled = o != NULL;
    if (!o)
        return VDBS_OK;
    if (!o->syntax) /* a flag without a value selects choice 1 */
        return vdbs_solver_option_set(scene, o, name, 1, err);
    if (o->kind == VDBS_OPTION_CHOICE)
        return vdbs_solver_option_choose(scene, o, name, value, err);
    vdbs_status st;
    if (o->kind == VDBS_OPTION_NUMBER) {
        double x = 0.0;
        if ((st = cli_number(name, value, &x, err)) != VDBS_OK)
            return st;
        if (!(x > o->min && x < o->max))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: expected a number in (%g, %g), got %s",
                                  name, o->min, o->max, value);
        return vdbs_solver_option_set(scene, o, name, x, err);
    }
    long k = 0;
    if ((st = cli_integer(name, value, (long)o->min, (long)o->max, &k, err)) != VDBS_OK)
        return st;
    if (o->even && k % 2 != 0)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: expected an even count (%s), got %ld", name,
                              o->even, k);
    return vdbs_solver_option_set(scene, o, name, (double)k, err);
}

void cli_solver_help(FILE *out)
{
    const vdbs_solver *s;
    fputs("\nmethods (--method):\n", out);
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m)
        fprintf(out, "  %-24s %s\n", s->name, s->summary);
    for (int m = 0; (s = vdbs_solver_at(m)) != NULL; ++m) {
        if (s->option_count == 0)
            continue;
        fprintf(out, "\n%s options (scene file keys solver.", s->name);
        for (int i = 0; i < s->option_count; ++i)
            fprintf(out, "%s%s", i ? ", " : "", s->options[i].key);
        fputs("):\n", out);
        for (int i = 0; i < s->option_count; ++i) {
            char text[1024];
            vdbs_solver_option_help(&s->options[i], text, sizeof text);
            fputs(text, out);
        }
    }
}
