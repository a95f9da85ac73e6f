/* The writers' temporary files (tempfile.h): the name, which stale ones are removed, and a text
 * output written whole or not at all (a full disk keeps the previous file).
 * The writers' behaviour under SIGKILL, full disks and concurrent writes is tested through
 * the CLI in test_faults_cli.py. */
#define _POSIX_C_SOURCE 200809L
#include "testutil.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include "vdbscatter/tempfile.h"

/* A PID no process has: one past the kernel's largest. */
static long dead_pid(void)
{
    FILE *f = fopen("/proc/sys/kernel/pid_max", "r");
    assert_non_null(f);
    long max = 0;
    assert_int_equal(fscanf(f, "%ld", &max), 1);
    fclose(f);
    return max + 1;
}

static const char *in_folder(const char *folder, const char *name)
{
    static char buf[4][4096];
    static int slot;
    char *out = buf[slot++ & 3];
    snprintf(out, 4096, "%s/%s", folder, name);
    return out;
}

static void touch(const char *path)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("x", f);
    fclose(f);
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void test_temp_path(void **state)
{
    (void)state;
    char want[256];
    char *tmp = vdbs_temp_path("some/dir/out.vdb");
    assert_non_null(tmp);
    snprintf(want, sizeof want, "some/dir/.out.vdb.tmp.%ld", (long)getpid());
    assert_string_equal(tmp, want);
    free(tmp);
    tmp = vdbs_temp_path("out.nvdb.json");
    assert_non_null(tmp);
    snprintf(want, sizeof want, ".out.nvdb.json.tmp.%ld", (long)getpid());
    assert_string_equal(tmp, want);
    free(tmp);
}

/* Only ".out.vdb.tmp.PID" regular files of dead PIDs go; live PIDs' (this process's, its
 * parent's, PID 1's), other names and a folder of the same name stay. */
static void test_remove_stale(void **state)
{
    (void)state;
    char folder[1024];
    snprintf(folder, sizeof folder, "%s", test_tmp_path("tempfile_stale_XXXXXX"));
    assert_non_null(mkdtemp(folder));
    const long dead = dead_pid();
    char stale[64], live[3][64], keep[6][64], dir[64];
    snprintf(stale, sizeof stale, ".out.vdb.tmp.%ld", dead);
    snprintf(live[0], sizeof live[0], ".out.vdb.tmp.%ld", (long)getpid());
    snprintf(live[1], sizeof live[1], ".out.vdb.tmp.%ld", (long)getppid());
    snprintf(live[2], sizeof live[2], ".out.vdb.tmp.1");
    snprintf(keep[0], sizeof keep[0], ".other.vdb.tmp.%ld", dead);
    snprintf(keep[1], sizeof keep[1], "out.vdb.tmp.%ld", dead);
    snprintf(keep[2], sizeof keep[2], ".out.vdb.tmp.0%ld", dead);
    snprintf(keep[3], sizeof keep[3], ".out.vdb.tmp.%ldx", dead);
    snprintf(keep[4], sizeof keep[4], ".out.vdb.tmp.");
    snprintf(keep[5], sizeof keep[5], ".out.vdb.tmp.99999999999");
    snprintf(dir, sizeof dir, ".out.vdb.tmp.%ld", dead + 1);
    touch(in_folder(folder, stale));
    for (int i = 0; i < 3; ++i)
        touch(in_folder(folder, live[i]));
    for (int i = 0; i < 6; ++i)
        touch(in_folder(folder, keep[i]));
    assert_int_equal(mkdir(in_folder(folder, dir), 0755), 0);

    vdbs_temp_remove_stale(in_folder(folder, "out.vdb"));
    assert_false(exists(in_folder(folder, stale)));
    for (int i = 0; i < 3; ++i)
        assert_true(exists(in_folder(folder, live[i])));
    for (int i = 0; i < 6; ++i)
        assert_true(exists(in_folder(folder, keep[i])));
    assert_true(exists(in_folder(folder, dir)));

    /* A bare name means the current folder. */
    char cwd[4096];
    assert_non_null(getcwd(cwd, sizeof cwd));
    touch(in_folder(folder, stale));
    assert_int_equal(chdir(folder), 0);
    vdbs_temp_remove_stale("out.vdb");
    assert_int_equal(chdir(cwd), 0);
    assert_false(exists(in_folder(folder, stale)));

    for (int i = 0; i < 3; ++i)
        remove(in_folder(folder, live[i]));
    for (int i = 0; i < 6; ++i)
        remove(in_folder(folder, keep[i]));
    rmdir(in_folder(folder, dir));
    assert_int_equal(rmdir(folder), 0);
}

static void read_text(const char *path, char *text, size_t size)
{
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    const size_t n = fread(text, 1, size - 1, f);
    text[n] = '\0';
    fclose(f);
}

static int temp_left(const char *path)
{
    char *tmp = vdbs_temp_path(path);
    const int left = exists(tmp);
    free(tmp);
    return left;
}

static void test_text_file(void **state)
{
    (void)state;
    const char *path = test_tmp_path("test_tempfile_report.csv");
    vdbs_text_file t;
    vdbs_error err;
    char text[256];
    assert_int_equal(vdbs_text_begin(&t, path, &err), VDBS_OK);
    fputs("first\n", t.stream);
    assert_int_equal(vdbs_text_commit(&t, &err), VDBS_OK);
    read_text(path, text, sizeof text);
    assert_string_equal(text, "first\n");
    assert_false(temp_left(path));

    /* A write past the file size limit fails (EFBIG; SIGXFSZ ignored, as test_faults_cli does
     * for the whole CLI): the previous file stays byte for byte, the temporary one goes. */
    struct rlimit old;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &old), 0);
    struct rlimit small = old;
    small.rlim_cur = 4096;
    void (*was)(int) = signal(SIGXFSZ, SIG_IGN);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &small), 0);
    assert_int_equal(vdbs_text_begin(&t, path, &err), VDBS_OK);
    for (int i = 0; i < 1000; ++i)
        fputs("a line of a large table that does not fit\n", t.stream);
    const vdbs_status st = vdbs_text_commit(&t, &err);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &old), 0);
    signal(SIGXFSZ, was);
    assert_int_equal(st, VDBS_ERR_IO);
    assert_non_null(strstr(err.message, path));
    assert_null(strchr(err.message, '\n'));
    read_text(path, text, sizeof text);
    assert_string_equal(text, "first\n");
    assert_false(temp_left(path));

    /* A folder that does not exist: refused at the start, nothing made. */
    const char *nowhere = test_tmp_path("no_such_folder/report.csv");
    assert_int_equal(vdbs_text_begin(&t, nowhere, &err), VDBS_ERR_IO);
    assert_non_null(strstr(err.message, nowhere));
    unlink(path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_temp_path),
        cmocka_unit_test(test_remove_stale),
        cmocka_unit_test(test_text_file),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
