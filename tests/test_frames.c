/* Frame tokens and lists (frames.h): every spelling of the token, padding, the list grammar
 * and its refusals, folding back into text, and scanning a folder. */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "testutil.h"
#include "vdbscatter/frames.h"

static void path_of(const char *pattern, long frame, const char *expected)
{
    vdbs_frame_token t;
    vdbs_error err;
    char out[256];
    assert_int_equal(vdbs_frame_token_find(pattern, "IN", &t, &err), VDBS_OK);
    assert_int_equal(vdbs_frame_path(pattern, &t, frame, out, sizeof out, &err), VDBS_OK);
    assert_string_equal(out, expected);
}

static void test_tokens(void **state)
{
    (void)state;
    path_of("smoke.####.vdb", 7, "smoke.0007.vdb");
    path_of("smoke.#.vdb", 123, "smoke.123.vdb");
    path_of("smoke.$F4.vdb", 12, "smoke.0012.vdb");
    path_of("smoke.$F.vdb", 12, "smoke.12.vdb");
    path_of("smoke.%04d.vdb", 12345, "smoke.12345.vdb"); /* wider than the padding */
    path_of("smoke.%d.vdb", 0, "smoke.0.vdb");
    path_of("shot_$F3/lit.vdb", 5, "shot_005/lit.vdb"); /* a folder per frame */
    path_of("100%%.####.vdb", 2, "100%%.0002.vdb");     /* "%%" is no token */
}

static void test_no_token_and_refusals(void **state)
{
    (void)state;
    vdbs_frame_token t;
    vdbs_error err;
    assert_int_equal(vdbs_frame_token_find("plain.vdb", "IN", &t, &err), VDBS_OK);
    assert_int_equal((int)t.length, 0);
    assert_int_equal(vdbs_frame_token_find("100%%.vdb", "IN", &t, &err), VDBS_OK);
    assert_int_equal((int)t.length, 0);
    /* two tokens, a stray %, and padding past 12 digits */
    assert_int_equal(vdbs_frame_token_find("a.####.$F4.vdb", "-o", &t, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "more than one"));
    assert_non_null(strstr(err.message, "-o"));
    assert_int_equal(vdbs_frame_token_find("a.%s.vdb", "IN", &t, &err), VDBS_ERR_INPUT);
    assert_int_equal(vdbs_frame_token_find("a.#############.vdb", "IN", &t, &err), VDBS_ERR_INPUT);
    /* a path that does not fit */
    char small[8];
    assert_int_equal(vdbs_frame_token_find("s.####.vdb", "IN", &t, &err), VDBS_OK);
    assert_int_equal(vdbs_frame_path("s.####.vdb", &t, 1, small, sizeof small, &err),
                     VDBS_ERR_INPUT);
}

static void list_is(const char *text, const long *frames, int count, const char *folded)
{
    vdbs_frame_list list;
    vdbs_error err;
    assert_int_equal(vdbs_frame_list_parse(text, &list, &err), VDBS_OK);
    assert_int_equal(list.count, count);
    for (int i = 0; i < count; ++i)
        assert_int_equal(list.frames[i], frames[i]);
    char out[256];
    vdbs_frame_list_format(&list, out, sizeof out);
    assert_string_equal(out, folded);
    /* the folded text parses back to the same list */
    vdbs_frame_list again;
    assert_int_equal(vdbs_frame_list_parse(out, &again, &err), VDBS_OK);
    assert_int_equal(again.count, count);
    assert_memory_equal(again.frames, list.frames, sizeof(long) * (size_t)count);
    vdbs_frame_list_free(&again);
    vdbs_frame_list_free(&list);
}

static void test_lists(void **state)
{
    (void)state;
    list_is("1-5", (const long[]){1, 2, 3, 4, 5}, 5, "1-5");
    list_is("1-9x4", (const long[]){1, 5, 9}, 3, "1-9x4");
    list_is("10-12x5", (const long[]){10}, 1, "10");
    list_is("7,3,1-2", (const long[]){1, 2, 3, 7}, 4, "1-3,7");
    list_is("0", (const long[]){0}, 1, "0");
    list_is("4,10", (const long[]){4, 10}, 2, "4,10");
    list_is("1-4,10-20x5", (const long[]){1, 2, 3, 4, 10, 15, 20}, 7, "1-4,10-20x5");
}

static void refused(const char *text, const char *needle)
{
    vdbs_frame_list list;
    vdbs_error err;
    assert_int_equal(vdbs_frame_list_parse(text, &list, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "--frames"));
    if (!strstr(err.message, needle))
        fail_msg("--frames %s: '%s' lacks '%s'", text, err.message, needle);
    assert_null(list.frames);
}

static void test_list_refusals(void **state)
{
    (void)state;
    refused("", "expected");
    refused("1,,2", "expected");
    refused("5-1", "backwards");
    refused("1-10x0", "step");
    refused("1-5,3", "twice");
    refused("-3", "not a frame");
    refused("a-b", "not a frame");
    refused("1-", "last frame");
    refused("1-1000000", "more than");
    refused("99999999", "not a frame");
}

static void test_scan(void **state)
{
    (void)state;
    char dir[512], path[600];
    snprintf(dir, sizeof dir, "%s/frames_scan_XXXXXX", VDBS_TEST_TMP_DIR);
    assert_non_null(mkdtemp(dir));
    /* the pattern's frames, and names that are not */
    const char *names[] = {"s.0001.vdb", "s.0003.vdb",     "s.0010.vdb", "s.12345.vdb",
                           "s.001.vdb",  "s.0002.vdb.tmp", "t.0004.vdb", "s.00a1.vdb"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i) {
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        FILE *f = fopen(path, "w");
        assert_non_null(f);
        fclose(f);
    }
    char pattern[600];
    snprintf(pattern, sizeof pattern, "%s/s.####.vdb", dir);
    vdbs_frame_token t;
    vdbs_frame_list list;
    vdbs_error err;
    assert_int_equal(vdbs_frame_token_find(pattern, "IN", &t, &err), VDBS_OK);
    assert_int_equal(vdbs_frame_list_scan(pattern, &t, &list, &err), VDBS_OK);
    assert_int_equal(list.count, 4);
    const long expected[] = {1, 3, 10, 12345};
    assert_memory_equal(list.frames, expected, sizeof expected);
    vdbs_frame_list_free(&list);
    /* unpadded: every count of digits, so s.001 and s.0001 are both frame 1 */
    snprintf(pattern, sizeof pattern, "%s/s.$F.vdb", dir);
    assert_int_equal(vdbs_frame_token_find(pattern, "IN", &t, &err), VDBS_OK);
    assert_int_equal(vdbs_frame_list_scan(pattern, &t, &list, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "twice"));
    for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i) {
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        unlink(path);
    }
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tokens), cmocka_unit_test(test_no_token_and_refusals),
        cmocka_unit_test(test_lists),  cmocka_unit_test(test_list_refusals),
        cmocka_unit_test(test_scan),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
