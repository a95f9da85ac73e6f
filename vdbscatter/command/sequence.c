#define _POSIX_C_SOURCE 200809L
#include "sequence.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include "vdbscatter/message.h"
#include "vdbscatter/progress.h"
#include "vdbscatter/readfile.h"
#include "vdbscatter/tempfile.h"
#include "vdbscatter/vdbio.h"

typedef enum vdbs_frame_status {
    VDBS_FRAME_PENDING = 0,
    VDBS_FRAME_DONE,       /* worked in this run */
    VDBS_FRAME_UP_TO_DATE, /* its output is there with the same hash: skipped */
    VDBS_FRAME_FAILED,
    VDBS_FRAME_MISSING, /* its input is missing (--skip-missing), or with --verify its output */
    VDBS_FRAME_STALE    /* --verify: its output has another hash */
} vdbs_frame_status;

typedef struct vdbs_sequence {
    const char *command;
    const char *input, *output; /* the patterns */
    vdbs_frame_token input_token, output_token;
    vdbs_frame_list list;
    vdbs_frame_status *status;
    double *seconds; /* per frame, of the work */
    cJSON **reports; /* per frame, or NULL */
    const char *summary_path;
    double fps;
    int json, quiet;
} vdbs_sequence;

static const char *const status_names[] = {"pending", "worked",  "up-to-date",
                                           "failed",  "missing", "stale"};

/* A frame's status as the summary and the progress lines name it: a worked frame is
 * "baked" or "rendered" (the step's word). */
static const char *status_name(const vdbs_sequence_step *step, vdbs_frame_status status)
{
    return status == VDBS_FRAME_DONE && step->worked ? step->worked : status_names[status];
}

int vdbs_sequence_requested(const vdbs_options_args *args, const char *input, const char *output)
{
    vdbs_frame_token t;
    vdbs_error err;
    if (vdbs_options_value(args, "--frames"))
        return 1;
    /* a malformed token is reported when the sequence opens */
    if (input && (vdbs_frame_token_find(input, "", &t, &err) != VDBS_OK || t.length))
        return 1;
    return output && (vdbs_frame_token_find(output, "", &t, &err) != VDBS_OK || t.length);
}

static int fail(const char *command, int status, const char *message)
{
    return vdbs_command_fail(command, status, message);
}

/* The frames whose inputs are not there, listed; an error unless --skip-missing. */
static int check_inputs(vdbs_sequence *s, int skip_missing)
{
    vdbs_frame_list missing = {0};
    missing.frames = malloc(sizeof *missing.frames * (size_t)(s->list.count ? s->list.count : 1));
    if (!missing.frames)
        return fail(s->command, VDBS_EXIT_FAILURE, "out of memory");
    for (int i = 0; i < s->list.count; ++i) {
        char path[VDBS_SEQUENCE_PATH_MAX];
        vdbs_error err;
        struct stat st;
        if (vdbs_frame_path(s->input, &s->input_token, s->list.frames[i], path, sizeof path,
                            &err) != VDBS_OK) {
            free(missing.frames);
            return fail(s->command, VDBS_EXIT_USAGE, err.message);
        }
        if (stat(path, &st) != 0) {
            missing.frames[missing.count++] = s->list.frames[i];
            s->status[i] = VDBS_FRAME_MISSING;
        }
    }
    int status = VDBS_EXIT_OK;
    if (missing.count) {
        char frames[512], message[1024];
        vdbs_frame_list_format(&missing, frames, sizeof frames);
        snprintf(message, sizeof message, "%s: %d of %d input frames missing: %s%s", s->input,
                 missing.count, s->list.count, frames,
                 skip_missing ? " (skipped)" : " (--skip-missing bakes the others)");
        if (!skip_missing || missing.count == s->list.count)
            status = fail(s->command, VDBS_EXIT_USAGE, message);
        else if (!s->quiet)
            vdbs_message_emitf(VDBS_MESSAGE_WARNING, "vdbscatter %s: warning: %s\n", s->command,
                               message);
    }
    free(missing.frames);
    return status;
}

static void sequence_close(vdbs_sequence *s);

/* Reads the frame list (--frames, or the input's frames on disk), checks the patterns and
 * lists missing inputs (an error unless --skip-missing). Returns VDBS_EXIT_OK, or the exit
 * status of bad input (said). */
static int sequence_open(const char *command, const vdbs_options_args *args, const char *input,
                         const char *output, vdbs_sequence **out)
{
    *out = NULL;
    vdbs_error err;
    vdbs_sequence *s = calloc(1, sizeof *s);
    if (!s)
        return fail(command, VDBS_EXIT_FAILURE, "out of memory");
    s->command = command;
    s->input = input;
    s->output = output;
    s->summary_path = vdbs_options_value(args, "--summary");
    s->json = vdbs_options_flag(args, "--json");
    s->quiet = vdbs_options_flag(args, "-q");
    int status = VDBS_EXIT_OK;
    const char *frames = vdbs_options_value(args, "--frames");
    const char *fps = vdbs_options_value(args, "--fps");
    if (vdbs_frame_token_find(input, "IN", &s->input_token, &err) != VDBS_OK ||
        (output && vdbs_frame_token_find(output, "-o", &s->output_token, &err) != VDBS_OK))
        status = fail(command, VDBS_EXIT_USAGE, err.message);
    else if (!s->input_token.length)
        status = fail(command, VDBS_EXIT_USAGE,
                      "a sequence needs a frame number in IN (smoke.####.vdb, smoke.$F4.vdb or "
                      "smoke.%04d.vdb)");
    else if (output && !s->output_token.length)
        status = fail(command, VDBS_EXIT_USAGE,
                      "-o: a sequence needs a frame number in the output too (####, $F4, %04d)");
    else if (fps && (vdbs_options_number("--fps", fps, &s->fps, &err) != VDBS_OK ||
                     !(s->fps > 0.0 && s->fps <= 1000.0)))
        status = fail(command, VDBS_EXIT_USAGE, "--fps: expected a frame rate in (0, 1000]");
    else if (frames ? vdbs_frame_list_parse(frames, &s->list, &err) != VDBS_OK
                    : vdbs_frame_list_scan(input, &s->input_token, &s->list, &err) != VDBS_OK)
        status = fail(command, VDBS_EXIT_USAGE, err.message);
    else if (s->list.count == 0)
        status = fail(command, VDBS_EXIT_USAGE,
                      "no input frames match the pattern (give --frames to name them)");
    if (status == VDBS_EXIT_OK) {
        const size_t n = (size_t)s->list.count;
        s->status = calloc(n, sizeof *s->status);
        s->seconds = calloc(n, sizeof *s->seconds);
        s->reports = calloc(n, sizeof *s->reports);
        if (!s->status || !s->seconds || !s->reports)
            status = fail(command, VDBS_EXIT_FAILURE, "out of memory");
    }
    if (status == VDBS_EXIT_OK)
        status = check_inputs(s, vdbs_options_flag(args, "--skip-missing"));
    if (status != VDBS_EXIT_OK) {
        sequence_close(s);
        return status;
    }
    *out = s;
    return VDBS_EXIT_OK;
}

static void sequence_close(vdbs_sequence *s)
{
    if (!s)
        return;
    for (int i = 0; s->reports && i < s->list.count; ++i)
        cJSON_Delete(s->reports[i]);
    vdbs_frame_list_free(&s->list);
    free(s->status);
    free(s->seconds);
    free(s->reports);
    free(s);
}

void vdbs_sequence_hash_text(const char *text, char hash[VDBS_SEQUENCE_HASH_SIZE])
{
    XXH128_hash_t h = XXH3_128bits(text, strlen(text));
    snprintf(hash, VDBS_SEQUENCE_HASH_SIZE, "%016llx%016llx", (unsigned long long)h.high64,
             (unsigned long long)h.low64);
}

vdbs_status vdbs_sequence_hash_file(const char *path, char hash[VDBS_SEQUENCE_HASH_SIZE],
                                    vdbs_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return vdbs_error_set(err, VDBS_ERR_IO, "%s: %s", path, strerror(errno));
    XXH3_state_t *state = XXH3_createState();
    char *buffer = malloc(1 << 20);
    if (!state || !buffer) {
        fclose(f);
        XXH3_freeState(state);
        free(buffer);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory to hash %s", path);
    }
    XXH3_128bits_reset(state);
    size_t n;
    while ((n = fread(buffer, 1, 1 << 20, f)) > 0)
        XXH3_128bits_update(state, buffer, n);
    const int failed = ferror(f);
    fclose(f);
    free(buffer);
    XXH128_hash_t h = XXH3_128bits_digest(state);
    XXH3_freeState(state);
    if (failed)
        return vdbs_error_set(err, VDBS_ERR_IO, "%s: a read failed", path);
    snprintf(hash, VDBS_SEQUENCE_HASH_SIZE, "%016llx%016llx", (unsigned long long)h.high64,
             (unsigned long long)h.low64);
    return VDBS_OK;
}

/* The determinants hash an existing output carries, or "" (no file, none in it, or a file
 * that is not a VDB: all of them "not done"). .nvdb outputs carry theirs in FILE.nvdb.json. */
static void output_hash(const char *path, char hash[VDBS_SEQUENCE_HASH_SIZE])
{
    hash[0] = '\0';
    struct stat st;
    if (stat(path, &st) != 0)
        return;
    const size_t n = strlen(path);
    vdbs_error err;
    if (n > 5 && strcmp(path + n - 5, ".nvdb") == 0) {
        char json_path[VDBS_SEQUENCE_PATH_MAX + 8];
        snprintf(json_path, sizeof json_path, "%s.json", path);
        char *text = NULL;
        size_t size = 0;
        if (vdbs_read_file(json_path, NULL, 1 << 24, &text, &size, &err) != VDBS_OK)
            return;
        cJSON *j = cJSON_Parse(text);
        const cJSON *h = cJSON_GetObjectItemCaseSensitive(j, VDBS_SEQUENCE_META_HASH);
        if (cJSON_IsString(h) && strlen(h->valuestring) < VDBS_SEQUENCE_HASH_SIZE)
            snprintf(hash, VDBS_SEQUENCE_HASH_SIZE, "%s", h->valuestring);
        cJSON_Delete(j);
        free(text);
        return;
    }
    char *value = NULL;
    if (vdbio_file_meta(path, VDBS_SEQUENCE_META_HASH, &value, &err) == VDBS_OK && value &&
        strlen(value) < VDBS_SEQUENCE_HASH_SIZE)
        snprintf(hash, VDBS_SEQUENCE_HASH_SIZE, "%s", value);
    free(value);
}

/* The summary: counts, per-frame times, the estimate of the time left, and each frame. */
static cJSON *summary_json(const vdbs_sequence *s, const vdbs_sequence_step *step, double elapsed,
                           double left)
{
    int counts[6] = {0};
    double worked = 0.0;
    for (int i = 0; i < s->list.count; ++i) {
        ++counts[s->status[i]];
        if (s->status[i] == VDBS_FRAME_DONE)
            worked += s->seconds[i];
    }
    char frames[1024];
    vdbs_frame_list_format(&s->list, frames, sizeof frames);
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "command", s->command);
    cJSON_AddStringToObject(j, "input", s->input);
    if (s->output)
        cJSON_AddStringToObject(j, "output", s->output);
    cJSON_AddStringToObject(j, "frame_list", frames);
    if (s->fps > 0.0)
        cJSON_AddNumberToObject(j, "fps", s->fps);
    cJSON_AddBoolToObject(j, "verify", step->verify);
    cJSON_AddNumberToObject(j, "frames_total", s->list.count);
    cJSON_AddNumberToObject(j, "done", counts[VDBS_FRAME_DONE] + counts[VDBS_FRAME_UP_TO_DATE]);
    cJSON_AddNumberToObject(j, "worked", counts[VDBS_FRAME_DONE]);
    cJSON_AddNumberToObject(j, "skipped", counts[VDBS_FRAME_UP_TO_DATE]);
    cJSON_AddNumberToObject(j, "failed", counts[VDBS_FRAME_FAILED]);
    cJSON_AddNumberToObject(j, "missing", counts[VDBS_FRAME_MISSING]);
    cJSON_AddNumberToObject(j, "stale", counts[VDBS_FRAME_STALE]);
    cJSON_AddNumberToObject(j, "pending", counts[VDBS_FRAME_PENDING]);
    cJSON_AddNumberToObject(j, "seconds_elapsed", elapsed);
    cJSON_AddNumberToObject(j, "seconds_per_frame",
                            counts[VDBS_FRAME_DONE] ? worked / counts[VDBS_FRAME_DONE] : 0.0);
    cJSON_AddNumberToObject(j, "seconds_left_estimate", left);
    cJSON *list = cJSON_AddArrayToObject(j, "frames");
    for (int i = 0; i < s->list.count; ++i) {
        cJSON *f = cJSON_CreateObject();
        char path[VDBS_SEQUENCE_PATH_MAX];
        vdbs_error err;
        cJSON_AddNumberToObject(f, "frame", (double)s->list.frames[i]);
        cJSON_AddStringToObject(f, "status", status_name(step, s->status[i]));
        if (vdbs_frame_path(s->input, &s->input_token, s->list.frames[i], path, sizeof path,
                            &err) == VDBS_OK)
            cJSON_AddStringToObject(f, "input", path);
        if (s->output && vdbs_frame_path(s->output, &s->output_token, s->list.frames[i], path,
                                         sizeof path, &err) == VDBS_OK)
            cJSON_AddStringToObject(f, "output", path);
        if (s->status[i] == VDBS_FRAME_DONE || s->status[i] == VDBS_FRAME_FAILED)
            cJSON_AddNumberToObject(f, "seconds", s->seconds[i]);
        if (s->reports[i])
            cJSON_AddItemReferenceToObject(f, "report", s->reports[i]);
        cJSON_AddItemToArray(list, f);
    }
    return j;
}

/* Writes text into path through a temporary file (a reader never sees half of it). */
static int write_text(const char *command, const char *path, const char *text)
{
    vdbs_text_file file;
    vdbs_error err;
    vdbs_status st = vdbs_text_begin(&file, path, &err);
    if (st == VDBS_OK) {
        fputs(text, file.stream);
        fputc('\n', file.stream);
        st = vdbs_text_commit(&file, &err);
    }
    return st == VDBS_OK ? VDBS_EXIT_OK : fail(command, VDBS_EXIT_FAILURE, err.message);
}

static int write_summary(const vdbs_sequence *s, const vdbs_sequence_step *step, double elapsed,
                         double left, int print)
{
    if (!s->summary_path && !print)
        return VDBS_EXIT_OK;
    cJSON *j = summary_json(s, step, elapsed, left);
    char *text = j ? cJSON_Print(j) : NULL;
    cJSON_Delete(j);
    if (!text)
        return fail(s->command, VDBS_EXIT_FAILURE, "out of memory for the summary");
    int status = VDBS_EXIT_OK;
    if (s->summary_path)
        status = write_text(s->command, s->summary_path, text);
    if (print)
        vdbs_command_out("%s\n", text);
    free(text);
    return status;
}

/* The frame's line: what happened, and the estimate of what is left. */
static void frame_line(const vdbs_sequence *s, const vdbs_sequence_step *step, int i, double left)
{
    char label[48], text[256], fields[256];
    snprintf(label, sizeof label, "frame %ld", s->list.frames[i]);
    const int remaining = s->list.count - i - 1;
    if (s->status[i] == VDBS_FRAME_DONE || s->status[i] == VDBS_FRAME_FAILED)
        snprintf(text, sizeof text, "%s in %.2fs (%d/%d; %d left, about %.0fs)",
                 status_name(step, s->status[i]), s->seconds[i], i + 1, s->list.count, remaining,
                 left);
    else
        snprintf(text, sizeof text, "%s (%d/%d)", status_name(step, s->status[i]), i + 1,
                 s->list.count);
    snprintf(fields, sizeof fields,
             "\"frame\": %ld, \"status\": \"%s\", \"index\": %d, \"frames_total\": %d, "
             "\"seconds\": %.3f, \"seconds_left_estimate\": %.3f",
             s->list.frames[i], status_name(step, s->status[i]), i + 1, s->list.count,
             s->seconds[i], left);
    vdbs_progress_event("frame", label, text, fields);
}

/* A frame's report into --report's frame path. */
static int write_report(const vdbs_sequence *s, const vdbs_sequence_step *step, long frame,
                        const cJSON *report)
{
    vdbs_frame_token token;
    vdbs_error err;
    char path[VDBS_SEQUENCE_PATH_MAX];
    if (vdbs_frame_token_find(step->report_pattern, "--report", &token, &err) != VDBS_OK ||
        vdbs_frame_path(step->report_pattern, &token, frame, path, sizeof path, &err) != VDBS_OK)
        return fail(s->command, VDBS_EXIT_USAGE, err.message);
    char *text = cJSON_Print(report);
    int status = text ? write_text(s->command, path, text)
                      : fail(s->command, VDBS_EXIT_FAILURE, "out of memory for the report");
    free(text);
    return status;
}

/* Works (or checks) every frame; returns the exit status. */
static int sequence_frames(vdbs_sequence *s, const vdbs_sequence_step *step)
{
    const double started = vdbs_now();
    const int lines = !step->quiet;
    int worked = 0, failed = 0, last_failure = VDBS_EXIT_OK;
    double worked_seconds = 0.0;
    for (int i = 0; i < s->list.count; ++i) {
        if (vdbs_cancelled(vdbs_command_cancel()))
            break;
        if (s->status[i] == VDBS_FRAME_MISSING)
            continue;
        vdbs_sequence_frame frame = {0};
        frame.frame = s->list.frames[i];
        frame.index = i;
        frame.fps = s->fps;
        vdbs_error err;
        if (vdbs_frame_path(s->input, &s->input_token, frame.frame, frame.input, sizeof frame.input,
                            &err) != VDBS_OK ||
            (s->output && vdbs_frame_path(s->output, &s->output_token, frame.frame, frame.output,
                                          sizeof frame.output, &err) != VDBS_OK)) {
            last_failure = fail(s->command, VDBS_EXIT_USAGE, err.message);
            break;
        }
        char previous[VDBS_SEQUENCE_PATH_MAX];
        if (i > 0 && s->output &&
            (s->status[i - 1] == VDBS_FRAME_DONE || s->status[i - 1] == VDBS_FRAME_UP_TO_DATE) &&
            vdbs_frame_path(s->output, &s->output_token, s->list.frames[i - 1], previous,
                            sizeof previous, &err) == VDBS_OK)
            frame.previous_output = previous;
        int status = VDBS_EXIT_OK;
        if (step->hash) {
            status = step->hash(step->user, &frame);
            if (status == VDBS_EXIT_OK && (!step->force || step->verify)) {
                char have[VDBS_SEQUENCE_HASH_SIZE];
                output_hash(frame.output, have);
                if (strcmp(have, frame.hash) == 0)
                    s->status[i] = VDBS_FRAME_UP_TO_DATE;
                else if (step->verify)
                    s->status[i] = have[0] || access(frame.output, F_OK) == 0 ? VDBS_FRAME_STALE
                                                                              : VDBS_FRAME_MISSING;
            }
        }
        if (status == VDBS_EXIT_OK && s->status[i] == VDBS_FRAME_PENDING) {
            const double t0 = vdbs_now();
            cJSON *report = NULL;
            status = step->run(step->user, &frame, &report);
            s->seconds[i] = vdbs_now() - t0;
            s->reports[i] = report;
            if (status == VDBS_EXIT_OK && report && step->report_pattern)
                status = write_report(s, step, frame.frame, report);
            if (status == VDBS_EXIT_OK) {
                s->status[i] = VDBS_FRAME_DONE;
                ++worked;
                worked_seconds += s->seconds[i];
            }
        }
        if (status != VDBS_EXIT_OK) {
            s->status[i] = VDBS_FRAME_FAILED;
            ++failed;
            last_failure = status;
            if (status >= 128) /* interrupted */
                break;
        }
        /* What is left, at the mean time of the frames worked so far. */
        int remaining = 0;
        for (int k = i + 1; k < s->list.count; ++k)
            remaining += s->status[k] == VDBS_FRAME_PENDING;
        const double left = worked ? worked_seconds / worked * remaining : 0.0;
        if (lines)
            frame_line(s, step, i, left);
        int st = write_summary(s, step, vdbs_now() - started, left, 0);
        if (st != VDBS_EXIT_OK)
            return st;
    }
    const int interrupted = vdbs_cancelled(vdbs_command_cancel());
    int st = write_summary(s, step, vdbs_now() - started, 0.0, s->json);
    if (st != VDBS_EXIT_OK)
        return st;
    if (interrupted || last_failure >= 128)
        return vdbs_command_interrupted(s->command, last_failure >= 128 ? last_failure : 1);
    int done = 0, not_done = 0;
    for (int i = 0; i < s->list.count; ++i) {
        done += s->status[i] == VDBS_FRAME_DONE || s->status[i] == VDBS_FRAME_UP_TO_DATE;
        not_done += s->status[i] == VDBS_FRAME_STALE ||
                    (step->verify && s->status[i] == VDBS_FRAME_MISSING);
    }
    if (!step->quiet && !s->json) {
        char text[256], fields[256];
        snprintf(text, sizeof text,
                 "%d of %d frames done (%d worked, %d up to date), %d failed, %d missing%s in "
                 "%.1fs",
                 done, s->list.count, worked, done - worked, failed, s->list.count - done - failed,
                 step->verify ? " or stale" : "", vdbs_now() - started);
        snprintf(fields, sizeof fields,
                 "\"frames_total\": %d, \"done\": %d, \"worked\": %d, \"failed\": %d",
                 s->list.count, done, worked, failed);
        /* a farm's log keeps it as one of its lines; a terminal gets a note */
        const vdbs_progress_style style = vdbs_progress_get_style();
        if (style == VDBS_PROGRESS_PLAIN || style == VDBS_PROGRESS_JSON)
            vdbs_progress_event("summary", "sequence", text, fields);
        else
            vdbs_message_emitf(VDBS_MESSAGE_NOTE, "%s: %s\n", s->command, text);
    }
    if (failed && done == 0)
        return last_failure;
    return failed || not_done ? VDBS_EXIT_PARTIAL : VDBS_EXIT_OK;
}

int vdbs_sequence_run(const vdbs_options_args *args, const char *input, const char *output,
                      const vdbs_sequence_step *step)
{
    vdbs_sequence *sequence = NULL;
    int status = sequence_open(step->command, args, input, output, &sequence);
    if (status != VDBS_EXIT_OK)
        return status;
    status = sequence_frames(sequence, step);
    sequence_close(sequence);
    return status;
}

int vdbs_sequence_refuse_flags(const char *command, const vdbs_options_args *args,
                               const char *const *own)
{
    static const char *const common[] = {"--skip-missing", "--fps", "--summary", NULL};
    const char *const *lists[] = {common, own};
    for (int l = 0; l < 2; ++l)
        for (const char *const *flag = lists[l]; flag && *flag; ++flag)
            if (vdbs_options_value(args, *flag) || vdbs_options_flag(args, *flag)) {
                char message[160];
                snprintf(message, sizeof message,
                         "%s works on frame sequences (give --frames, or a frame number in IN "
                         "and -o: smoke.####.vdb)",
                         *flag);
                return fail(command, VDBS_EXIT_USAGE, message);
            }
    return VDBS_EXIT_OK;
}
