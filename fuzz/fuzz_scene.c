/* The scene JSON parser. Whatever it accepts must validate or be refused in one line, and
 * must survive its own serialisation: vdbs_scene_to_json's text parses back. */
#include "fuzz_util.h"
#include "vdbscatter/scene.h"
#include "vdbscatter/scene_file.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *text = malloc(size + 1);
    vdbs_scene *scene = malloc(sizeof *scene);
    vdbs_scene *again = malloc(sizeof *again);
    if (!text || !scene || !again)
        abort();
    memcpy(text, data, size);
    text[size] = '\0';
    vdbs_error err;
    vdbs_status st = vdbs_scene_parse(text, "/nonexistent", scene, &err);
    fuzz_check_error(st, &err, "vdbs_scene_parse");
    if (st == VDBS_OK) {
        char *json = vdbs_scene_to_json(scene);
        if (json) {
            st = vdbs_scene_parse(json, NULL, again, &err);
            if (st != VDBS_OK) {
                fprintf(stderr, "fuzz: the scene's own JSON does not parse back: %s\n%s\n",
                        err.message, json);
                abort();
            }
            free(json);
        }
        st = vdbs_scene_validate(scene, &err);
        fuzz_check_error(st, &err, "vdbs_scene_validate");
    }
    free(again);
    free(scene);
    free(text);
    return 0;
}
