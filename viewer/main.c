/* vdbscatter-view LIT.vdb: an interactive window on a lit VDB. Every frame is the ray-march
 * kernel of `render --mode baked` (vdbs_march_session: the same kernel text, C path or
 * compute shader in the window's own GL context), shown with exposure; the camera orbits,
 * the light moves (its light grids rebuilt), and a key re-bakes the multiple scattering in
 * the background with the library; a VDB baked with inet keeps its multiple scattering live
 * instead (inet_live.h: a few warm sweeps a frame). --screenshot renders in a hidden window
 * and saves. */
#define _POSIX_C_SOURCE 200809L
#include <epoxy/gl.h>

#include <GLFW/glfw3.h>

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

#include "display.h"
#include "occluders.h"
#include "options.h"
#include "orbit.h"
#include "vdbscatter/bake.h"
#include "vdbscatter/camera.h"
#include "vdbscatter/fog.h"
#include "vdbscatter/inet_live.h"
#include "vdbscatter/runner.h"
#include "vdbscatter/litvdb.h"
#include "vdbscatter/march_session.h"
#include "vdbscatter/mesh.h"
#include "vdbscatter/render.h"
#include "vdbscatter/scene_file.h"
#include "vdbscatter/vdbio.h"

#define PROGRAM "vdbscatter-view"
#define DEFAULT_INTERLEAVE 2
#define MOVING_SECONDS 0.25 /* input this recent: draw with coarser steps */
#define SHADOW_MAP_RES 1024 /* a sun's map; a point light's cube faces are half as wide */
#define FOG_STEPS 64        /* shadow-map tests along a view ray through the fog */
#define DEFAULT_INET_SWEEPS 1

static const char help[] =
    "usage: vdbscatter-view LIT.vdb [options]\n"
    "\n"
    "Shows a lit VDB written by `vdbscatter bake`: every frame is the ray march of\n"
    "`vdbscatter render --mode baked` (single scattering toward the camera from light grids\n"
    "plus the baked multiple scattering). A density-only VDB opens too, single scattering\n"
    "only. Moving a light rebuilds its light grids at once; the baked multiple scattering\n"
    "then belongs to the old light until `b` re-bakes it in the background. A VDB baked\n"
    "with --method inet keeps it live instead: its network is rebuilt at start (solved\n"
    "cold, or from the file's state when baked with --keep-state) and every frame after\n"
    "a light change runs --inet-sweeps warm sweeps and shows their result.\n"
    "\n"
    "scene (as render; flags override --scene, light flags replace the scene's lights):\n"
    "  --scene FILE.json  --grid NAME[@INDEX]  --density-scale S  --albedo A|R,G,B  --g G\n"
    "  --sun DX,DY,DZ[:R,G,B]  --point X,Y,Z[:R,G,B]  --env R,G,B|FILE[:S]\n"
    "  --quality low|medium|high|ultra  --sky-directions K  --s1 grid|march\n"
    "  --s1-oversample F\n"
    "\n"
    "view:\n"
    "  --camera PX,PY,PZ:TX,TY,TZ:FOV   start camera (default: the scene's, else the volume)\n"
    "  --size WxH               window and picture size (default: the camera's, else 640x480)\n"
    "  --exposure EV            display exposure (default 0)\n"
    "  --fog SIGMA_T[:ALBEDO]   a homogeneous fog (albedo one number or R,G,B; default 1) in\n"
    "                           the scene's fog box, else the volume's bounds; replaces the\n"
    "                           scene's fog sigma_t and albedo (0 turns it off)\n"
    "  --rebake                 re-bake the multiple scattering for the given lights before\n"
    "                           showing it (as the key b does), e.g. after --sun\n"
    "  --inet-sweeps N          a VDB baked with inet: warm sweeps of its live multiple\n"
    "                           scattering per frame after a light change (default 1; 0: no\n"
    "                           live update, the baked one stays stale as for other methods)\n"
    "  --interleave M           interleaved sampling over M x M pixels, 2..4 (default 2)\n"
    "  --no-interleave          one full set of march steps in every pixel\n"
    "  --backend auto|cpu|gpu   the march on the C path or as a compute shader in the\n"
    "                           window's GL context (auto: gpu on a hardware GPU)\n"
    "  --screenshot OUT.png|OUT.exr   render in a hidden window, save the last frame, exit\n"
    "                           (.exr: linear floats as render writes; .png: with exposure)\n"
    "  --warmup-frames N        frames drawn for the screenshot, the last one saved (default 1)\n"
    "  --json                   with --screenshot: size, frame times, backend and the live\n"
    "                           multiple scattering's sweeps and change as JSON\n"
    "  -q                       no summary or warnings\n"
    "\n"
    "mouse: left drag orbits, middle drag (or shift + left) pans, wheel zooms,\n"
    "right drag turns the first light (a sun's direction, a point light around the volume)\n";

static const char keys_help[] =
    "keys:\n"
    "  arrows      turn the first light            1 / 2 / 3   single / multiple / both\n"
    "  i           interleaved sampling on/off     m           interleave block 2 -> 3 -> 4\n"
    "  [ / ]       coarser / finer march steps     - / =       exposure down / up (EV)\n"
    "  b           re-bake the multiple scattering for the current light (background)\n"
    "  r           reset the camera                h           this help\n"
    "  q / Esc     quit\n";

static const vdbs_arg_option options[] = {
    {"--scene", VDBS_ARG_VALUE},
    {"--grid", VDBS_ARG_VALUE},
    {"--density-scale", VDBS_ARG_VALUE},
    {"--albedo", VDBS_ARG_VALUE},
    {"--g", VDBS_ARG_VALUE},
    {"--sun", VDBS_ARG_LIST},
    {"--point", VDBS_ARG_LIST},
    {"--env", VDBS_ARG_LIST},
    {"--quality", VDBS_ARG_VALUE},
    {"--sky-directions", VDBS_ARG_VALUE},
    {"--s1", VDBS_ARG_VALUE},
    {"--s1-oversample", VDBS_ARG_VALUE},
    {"--camera", VDBS_ARG_VALUE},
    {"--size", VDBS_ARG_VALUE},
    {"--exposure", VDBS_ARG_VALUE},
    {"--interleave", VDBS_ARG_VALUE},
    {"--no-interleave", VDBS_ARG_FLAG},
    {"--backend", VDBS_ARG_VALUE},
    {"--screenshot", VDBS_ARG_VALUE},
    {"--json", VDBS_ARG_FLAG},
    {"--fog", VDBS_ARG_VALUE},
    {"--rebake", VDBS_ARG_FLAG},
    {"--warmup-frames", VDBS_ARG_VALUE},
    {"--inet-sweeps", VDBS_ARG_VALUE},
    {"-q", VDBS_ARG_FLAG},
    {NULL, VDBS_ARG_FLAG},
};

static int fail(int status, const char *message)
{
    fprintf(stderr, PROGRAM ": %s\n", message);
    return status == VDBS_ERR_INPUT ? VDBS_EXIT_USAGE : VDBS_EXIT_FAILURE;
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int has_suffix(const char *path, const char *suffix)
{
    size_t n = strlen(path), m = strlen(suffix);
    return n > m && strcasecmp(path + n - m, suffix) == 0;
}

/* A re-bake of the multiple scattering on a worker thread (the C path: the GL context
 * belongs to the window's thread), into a temporary lit VDB read back when done. */
typedef struct rebake {
    pthread_t thread;
    int running;
    volatile int done; /* set by the worker */
    vdbs_status status;
    vdbs_error err;
    vdbs_scene *scene;
    char input[VDBS_PATH_MAX];
    char output[64];
} rebake;

static void *rebake_main(void *user)
{
    rebake *job = user;
    vdbs_bake_options bo = {0};
    bo.input = job->input;
    bo.output = job->output;
    bo.scene = job->scene;
    bo.backend = VDBS_BACKEND_CPU;
    vdbs_bake_report report;
    job->status = vdbs_bake(&bo, &report, &job->err);
    __atomic_store_n(&job->done, 1, __ATOMIC_RELEASE);
    return NULL;
}

typedef struct viewer {
    const char *input;
    vdbs_runner *runner;
    vdbs_render_input in;
    vdbs_march_session *session;
    vdbs_march_options march;
    view_display display;
    view_orbit orbit, orbit_home;
    vdbs_camera size; /* width and height */
    vdbs_image image;
    double exposure;
    int interleave_on, interleave;
    float step_scale; /* [ and ] */
    int show_single, show_multiple;
    int ms_stale;
    int relit; /* the light moved: S1 from swept light grids, no longer the stored depths */
    int dirty;
    double last_input;
    double frame_ms;
    double open_ms; /* loading, the window and the session: before the first frame starts */
    double centre[3];
    int dragging; /* 0, 1 orbit, 2 pan, 3 light */
    double drag_x, drag_y;
    rebake bake;
    char message[VDBS_ERROR_MAX + 32]; /* last error of an interactive action, shown in the title */
    /* Solid occluders and the homogeneous fog of the scene file. */
    view_occluders occluders;
    vdbs_shadow_table shadows;
    double scene_lo[3], scene_hi[3]; /* what the sun maps cover */
    float *backdrop;
    vdbs_fog fog;
    vdbs_march_fog march_fog; /* march_fog.fog is NULL without a fog */
    /* Live multiple scattering of a VDB baked with inet: created for the file's own lights;
     * active once the lights differ from them. */
    vdbs_inet_live *live;
    int live_active;
    int live_pending; /* sweeps ran since the session's ms were last replaced */
    int inet_sweeps;  /* per frame */
    float *live_ms, *live_l1[3];
    vdbs_inet_live_status live_status;
    double live_update_ms; /* the last frame's sweeps, ms and upload */
} viewer;

/* The session's new lighting to the shadow-map consumers: the render kernel (through the
 * session) and the occluders' surfaces. */
static void occluder_lighting(viewer *v)
{
    vdbs_march_session_set_shadows(v->session, v->shadows.data, v->shadows.floats);
    vdbs_march_tables tables;
    vdbs_march_session_tables(v->session, &tables);
    view_occluders_set_lighting(&v->occluders, &tables, v->in.volume.world_to_index, &v->shadows);
}

/* The occluders' shadow maps for the current lights, handed to the session. */
static vdbs_status update_shadows(viewer *v, vdbs_error *err)
{
    if (v->occluders.count == 0)
        return VDBS_OK;
    vdbs_shadow_table_free(&v->shadows);
    vdbs_status st = view_occluders_shadow_maps(&v->occluders, v->in.scene, v->scene_lo,
                                                v->scene_hi, SHADOW_MAP_RES, &v->shadows, err);
    if (st == VDBS_OK)
        occluder_lighting(v);
    return st;
}

static void volume_centre(const vdbs_volume *volume, double centre[3])
{
    vdbs_camera cam;
    vdbs_camera_frame_volume(volume, 16, 16, &cam);
    memcpy(centre, cam.target, sizeof cam.target);
}

/* The march options of the next frame. */
static vdbs_march_options frame_options(const viewer *v, int moving)
{
    vdbs_march_options o = v->march;
    o.step_voxels = v->march.step_voxels * v->step_scale * (moving ? 2.0f : 1.0f);
    o.interleave = v->interleave_on ? v->interleave : 0;
    o.no_single = !v->show_single;
    o.no_multiple = !v->show_multiple;
    return o;
}

/* The frame's live multiple scattering: K warm sweeps, and their ms into the session. */
static vdbs_status live_update(viewer *v, vdbs_error *err)
{
    if (!v->live_active)
        return VDBS_OK;
    double t0 = now();
    const int before = v->live_status.sweeps;
    vdbs_status st = vdbs_inet_live_sweep(v->live, v->inet_sweeps, &v->live_status, err);
    if (st == VDBS_OK && v->live_status.sweeps != before)
        v->live_pending = 1;
    if (st == VDBS_OK && v->live_pending) {
        st = vdbs_inet_live_ms(v->live, v->live_ms, v->live_l1, err);
        if (st == VDBS_OK)
            st = vdbs_march_session_set_ms(v->session, v->live_ms, v->live_l1, err);
        v->live_pending = st != VDBS_OK;
    }
    v->live_update_ms = 1e3 * (now() - t0);
    return st;
}

static vdbs_status draw_frame(viewer *v, int moving, vdbs_error *err)
{
    vdbs_camera camera;
    view_orbit_camera(&v->orbit, &v->size, &camera);
    vdbs_camera_frame frame;
    vdbs_status st = vdbs_camera_frame_init(&camera, &frame, err);
    vdbs_march_options o = frame_options(v, moving);
    double t0 = now();
    if (st == VDBS_OK)
        st = live_update(v, err);
    if (st == VDBS_OK && v->occluders.count > 0) {
        st = view_occluders_backdrop(&v->occluders, &frame, v->backdrop, err);
        o.backdrop = v->backdrop;
    }
    if (v->march_fog.fog)
        o.fog = &v->march_fog;
    if (st == VDBS_OK)
        st = vdbs_march_session_draw(v->session, &frame, &o, &v->image, err);
    v->frame_ms = 1e3 * (now() - t0);
    return st;
}

static void set_title(GLFWwindow *window, const viewer *v)
{
    const char *terms = v->show_single && v->show_multiple ? "single+multiple"
                        : v->show_single                   ? "single"
                                                           : "multiple";
    char interleave[32] = "interleave off";
    if (v->interleave_on)
        snprintf(interleave, sizeof interleave, "interleave %dx%d", v->interleave, v->interleave);
    char live[96] = "";
    if (v->live_active && v->live_status.converged)
        snprintf(live, sizeof live, " | ms live: converged (%d sweeps)", v->live_status.sweeps);
    else if (v->live_active)
        snprintf(live, sizeof live, " | ms live: %d sweeps, change %.1e", v->live_status.sweeps,
                 v->live_status.change);
    char title[VDBS_ERROR_MAX + 512];
    snprintf(title, sizeof title, PROGRAM " | %.1f ms | %s | %s | step %.3g vox | EV %+.1f%s%s%s%s",
             v->frame_ms, v->in.mode == VDBS_RENDER_BAKED ? terms : "single (density only)",
             interleave, (double)(v->march.step_voxels * v->step_scale), v->exposure, live,
             v->bake.running ? " | re-baking..."
             : v->ms_stale   ? " | multiple scattering stale: b re-bakes"
                             : "",
             v->message[0] ? " | " : "", v->message);
    glfwSetWindowTitle(window, title);
}

static void touch(viewer *v)
{
    v->dirty = 1;
    v->last_input = now();
}

/* The scene's lights into the live multiple scattering: from here on it is shown. */
static vdbs_status live_relight(viewer *v, vdbs_error *err)
{
    vdbs_status st = vdbs_inet_live_set_lights(v->live, v->in.scene, err);
    if (st == VDBS_OK)
        v->live_active = 1;
    vdbs_inet_live_sweep(v->live, 0, &v->live_status, err);
    return st;
}

static void light_moved(viewer *v, double yaw, double pitch)
{
    if (!view_light_turn(v->in.scene, 0, v->centre, yaw, pitch))
        return;
    vdbs_error err;
    /* The lit VDB's stored depths were for the baked light: from here on they are swept. */
    if (v->march.stored_depths && !v->relit)
        snprintf(v->message, sizeof v->message, "the light moved: relighting single scattering");
    v->relit = 1;
    if (vdbs_march_session_set_scene(v->session, v->in.scene, &err) != VDBS_OK ||
        update_shadows(v, &err) != VDBS_OK)
        snprintf(v->message, sizeof v->message, "%s", err.message);
    if (v->live) {
        if (live_relight(v, &err) != VDBS_OK)
            snprintf(v->message, sizeof v->message, "%s", err.message);
    } else {
        v->ms_stale = v->in.mode == VDBS_RENDER_BAKED;
    }
    touch(v);
}

static void start_rebake(viewer *v)
{
    if (v->bake.running || v->in.mode != VDBS_RENDER_BAKED)
        return;
    rebake *job = &v->bake;
    job->scene = malloc(sizeof *job->scene);
    if (!job->scene)
        return;
    *job->scene = *v->in.scene;
    /* The method the VDB was baked with (a scene file may name another, or "single"). */
    snprintf(job->scene->method, sizeof job->scene->method, "%s", v->in.baked_method);
    snprintf(job->scene->grid, sizeof job->scene->grid, "density");
    job->scene->grid_index = 0;
    snprintf(job->input, sizeof job->input, "%s", v->input);
    snprintf(job->output, sizeof job->output, "/tmp/vdbscatter-view-%ld.vdb", (long)getpid());
    job->done = 0;
    if (pthread_create(&job->thread, NULL, rebake_main, job) != 0) {
        free(job->scene);
        snprintf(v->message, sizeof v->message, "could not start the re-bake");
        return;
    }
    job->running = 1;
    touch(v);
}

/* Takes a finished re-bake's multiple scattering into the session. */
/* Takes a finished re-bake's multiple scattering into the session; with `wait`, waits for it.
 * Returns what went wrong (also shown in the title). */
static vdbs_status finish_rebake(viewer *v, int wait, vdbs_error *err)
{
    rebake *job = &v->bake;
    if (!job->running || (!wait && !__atomic_load_n(&job->done, __ATOMIC_ACQUIRE)))
        return VDBS_OK;
    pthread_join(job->thread, NULL);
    job->running = 0;
    free(job->scene);
    vdbs_status st = job->status;
    vdbs_lit_grids ms;
    memset(&ms, 0, sizeof ms);
    if (st == VDBS_OK) {
        vdbio_lit *lit = NULL;
        st = vdbio_lit_open(job->output, &lit, err);
        if (st == VDBS_OK) {
            st = vdbs_lit_grids_load(lit, v->in.volume.index_to_world, 0, &ms, err);
            vdbio_lit_close(lit);
        }
    } else {
        *err = job->err;
    }
    remove(job->output);
    if (st == VDBS_OK) {
        /* The session reads in.ms: a new one over the new grids. */
        vdbs_march_session_destroy(v->session);
        v->session = NULL;
        vdbs_lit_grids_free(&v->in.ms);
        v->in.ms = ms;
        st = vdbs_march_session_create(v->runner, &v->in.volume, &v->in.ms, v->in.scene, &v->march,
                                       &v->session, err);
        if (st == VDBS_OK && v->occluders.count > 0)
            occluder_lighting(v);
        v->ms_stale = 0;
    } else {
        vdbs_lit_grids_free(&ms);
    }
    if (st != VDBS_OK)
        snprintf(v->message, sizeof v->message, "re-bake failed: %s", err->message);
    touch(v);
    return st;
}

static void on_key(GLFWwindow *window, int key, int scancode, int action, int mods)
{
    (void)scancode;
    (void)mods;
    viewer *v = glfwGetWindowUserPointer(window);
    if (action != GLFW_PRESS && action != GLFW_REPEAT)
        return;
    const double turn = 0.05;
    switch (key) {
    case GLFW_KEY_ESCAPE:
    case GLFW_KEY_Q:
        glfwSetWindowShouldClose(window, 1);
        return;
    case GLFW_KEY_H:
        fputs(keys_help, stdout);
        fflush(stdout);
        return;
    case GLFW_KEY_LEFT:
        light_moved(v, -turn, 0.0);
        return;
    case GLFW_KEY_RIGHT:
        light_moved(v, turn, 0.0);
        return;
    case GLFW_KEY_UP:
        light_moved(v, 0.0, turn);
        return;
    case GLFW_KEY_DOWN:
        light_moved(v, 0.0, -turn);
        return;
    case GLFW_KEY_1:
        v->show_single = 1;
        v->show_multiple = 0;
        break;
    case GLFW_KEY_2:
        v->show_single = 0;
        v->show_multiple = 1;
        break;
    case GLFW_KEY_3:
        v->show_single = v->show_multiple = 1;
        break;
    case GLFW_KEY_I:
        v->interleave_on = !v->interleave_on;
        break;
    case GLFW_KEY_M:
        v->interleave = v->interleave >= VDBS_MAX_INTERLEAVE ? 2 : v->interleave + 1;
        break;
    case GLFW_KEY_LEFT_BRACKET:
        v->step_scale = v->step_scale < 16.0f ? v->step_scale * 2.0f : v->step_scale;
        break;
    case GLFW_KEY_RIGHT_BRACKET:
        v->step_scale = v->step_scale > 1.0f / 16.0f ? v->step_scale * 0.5f : v->step_scale;
        break;
    case GLFW_KEY_MINUS:
        v->exposure -= 0.5;
        break;
    case GLFW_KEY_EQUAL:
        v->exposure += 0.5;
        break;
    case GLFW_KEY_B:
        start_rebake(v);
        return;
    case GLFW_KEY_R:
        v->orbit = v->orbit_home;
        break;
    default:
        return;
    }
    touch(v);
}

static void on_button(GLFWwindow *window, int button, int action, int mods)
{
    viewer *v = glfwGetWindowUserPointer(window);
    if (action == GLFW_RELEASE) {
        v->dragging = 0;
        touch(v); /* refine once the drag ends */
        return;
    }
    glfwGetCursorPos(window, &v->drag_x, &v->drag_y);
    if (button == GLFW_MOUSE_BUTTON_LEFT)
        v->dragging = (mods & GLFW_MOD_SHIFT) ? 2 : 1;
    else if (button == GLFW_MOUSE_BUTTON_MIDDLE)
        v->dragging = 2;
    else if (button == GLFW_MOUSE_BUTTON_RIGHT)
        v->dragging = 3;
}

static void on_cursor(GLFWwindow *window, double x, double y)
{
    viewer *v = glfwGetWindowUserPointer(window);
    if (!v->dragging)
        return;
    double dx = x - v->drag_x, dy = y - v->drag_y;
    v->drag_x = x;
    v->drag_y = y;
    if (v->dragging == 1)
        view_orbit_rotate(&v->orbit, dx, dy);
    else if (v->dragging == 2)
        view_orbit_pan(&v->orbit, dx, dy, v->size.height);
    else
        light_moved(v, 0.01 * dx, -0.01 * dy);
    touch(v);
}

static void on_scroll(GLFWwindow *window, double dx, double dy)
{
    (void)dx;
    viewer *v = glfwGetWindowUserPointer(window);
    view_orbit_zoom(&v->orbit, dy);
    touch(v);
}

static void on_glfw_error(int code, const char *description)
{
    (void)code;
    fprintf(stderr, PROGRAM ": GLFW: %s\n", description);
}

typedef struct view_args {
    vdbs_render_desc desc;
    vdbs_camera camera;
    vdbs_backend backend;
    const char *screenshot;
    long warmup;
    long interleave;
    int no_interleave;
    double exposure;
    int quiet;
    int json;
    int rebake;
    long inet_sweeps;
} view_args;

static vdbs_status parse_view_args(const vdbs_options_args *args, view_args *a, vdbs_error *err)
{
    vdbs_status st;
    const char *v;
    a->warmup = 1;
    a->interleave = DEFAULT_INTERLEAVE;
    a->inet_sweeps = DEFAULT_INET_SWEEPS;
    if ((v = vdbs_options_value(args, "--backend")) &&
        (st = vdbs_backend_parse(v, &a->backend, err)))
        return st;
    if ((st = vdbs_options_s1(args, &a->desc.s1_march, &a->desc.s1_oversample, err)) != VDBS_OK)
        return st;
    if ((v = vdbs_options_value(args, "--size")) &&
        (st = vdbs_options_size(v, &a->desc.width, &a->desc.height, err)) != VDBS_OK)
        return st;
    if ((v = vdbs_options_value(args, "--camera"))) {
        if ((st = vdbs_options_camera(v, &a->camera, err)) != VDBS_OK)
            return st;
        a->desc.camera = &a->camera;
    }
    if ((v = vdbs_options_value(args, "--exposure")) &&
        (st = vdbs_options_number("--exposure", v, &a->exposure, err)) != VDBS_OK)
        return st;
    if ((v = vdbs_options_value(args, "--interleave")) &&
        (st = vdbs_options_integer("--interleave", v, 2, VDBS_MAX_INTERLEAVE, &a->interleave,
                                   err)) != VDBS_OK)
        return st;
    a->no_interleave = vdbs_options_flag(args, "--no-interleave");
    if ((v = vdbs_options_value(args, "--inet-sweeps")) &&
        (st = vdbs_options_integer("--inet-sweeps", v, 0, 1000, &a->inet_sweeps, err)) != VDBS_OK)
        return st;
    if ((v = vdbs_options_value(args, "--warmup-frames")) &&
        (st = vdbs_options_integer("--warmup-frames", v, 1, 100000, &a->warmup, err)) != VDBS_OK)
        return st;
    if ((a->screenshot = vdbs_options_value(args, "--screenshot")) &&
        !has_suffix(a->screenshot, ".png") && !has_suffix(a->screenshot, ".exr"))
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "--screenshot: unsupported image type '%s' (use .exr or .png)",
                              a->screenshot);
    if (vdbs_options_value(args, "--warmup-frames") && !a->screenshot)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--warmup-frames needs --screenshot");
    a->quiet = vdbs_options_flag(args, "-q");
    a->json = vdbs_options_flag(args, "--json");
    a->rebake = vdbs_options_flag(args, "--rebake");
    if (a->json && !a->screenshot)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--json needs --screenshot");
    return VDBS_OK;
}

/* The scene file's occluders (their meshes and shadow maps) and fog (its tables), over the
 * box of the volume, the fog and the finite occluders. */
static vdbs_status open_occluders_and_fog(viewer *v, vdbs_error *err)
{
    const vdbs_scene *scene = v->in.scene;
    vdbs_volume_support_bounds(&v->in.volume, v->scene_lo, v->scene_hi);
    double volume_lo[3], volume_hi[3];
    memcpy(volume_lo, v->scene_lo, sizeof volume_lo);
    memcpy(volume_hi, v->scene_hi, sizeof volume_hi);
    vdbs_status st = view_occluders_init(&v->occluders, scene, v->centre,
                                         vdbs_volume_support_extent(&v->in.volume), err);
    if (st != VDBS_OK)
        return st;
    for (int a = 0; a < 3; ++a) {
        if (v->occluders.finite) {
            v->scene_lo[a] = fmin(v->scene_lo[a], v->occluders.finite_lo[a]);
            v->scene_hi[a] = fmax(v->scene_hi[a], v->occluders.finite_hi[a]);
        }
        if (scene->fog.present && scene->fog.has_box) {
            v->scene_lo[a] = fmin(v->scene_lo[a], scene->fog.box_min[a]);
            v->scene_hi[a] = fmax(v->scene_hi[a], scene->fog.box_max[a]);
        }
    }
    if (scene->fog.present && scene->fog.sigma_t > 0.0) {
        vdbs_fog_desc fd = {0};
        fd.sigma_t = scene->fog.sigma_t;
        fd.albedo = 1.0; /* the colour's albedo applies per channel (vdbs_march_fog) */
        fd.g = scene->fog.g;
        if ((st = vdbs_fog_build(&fd, &v->fog, err)) != VDBS_OK)
            return st;
        v->march_fog.fog = &v->fog;
        v->march_fog.steps = FOG_STEPS;
        for (int a = 0; a < 3; ++a) {
            v->march_fog.box_lo[a] = scene->fog.has_box ? scene->fog.box_min[a] : volume_lo[a];
            v->march_fog.box_hi[a] = scene->fog.has_box ? scene->fog.box_max[a] : volume_hi[a];
            v->march_fog.albedo[a] = scene->fog.albedo[a];
        }
    }
    view_occluders_set_fog(&v->occluders, &v->march_fog);
    if (v->occluders.count > 0) {
        v->backdrop =
            malloc(sizeof *v->backdrop * 4 * (size_t)v->size.width * (size_t)v->size.height);
        if (!v->backdrop)
            return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the occluders");
    }
    return update_shadows(v, err);
}

/* --fog SIGMA_T[:ALBEDO] into the scene's fog (its box, if any, stays). */
static vdbs_status parse_fog(const char *text, vdbs_scene *scene, vdbs_error *err)
{
    char sigma[64];
    const char *colon = strchr(text, ':');
    size_t n = colon ? (size_t)(colon - text) : strlen(text);
    if (n >= sizeof sigma)
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--fog: expected SIGMA_T[:ALBEDO], got '%s'",
                              text);
    memcpy(sigma, text, n);
    sigma[n] = '\0';
    double sigma_t = 0.0, albedo[3] = {1.0, 1.0, 1.0};
    vdbs_status st = vdbs_options_number("--fog", sigma, &sigma_t, err);
    if (st == VDBS_OK && colon)
        st = vdbs_options_triple("--fog", colon + 1, 1, albedo, err);
    if (st != VDBS_OK)
        return st;
    if (!(sigma_t >= 0.0))
        return vdbs_error_set(err, VDBS_ERR_INPUT, "--fog: SIGMA_T must be >= 0, got %g", sigma_t);
    for (int c = 0; c < 3; ++c)
        if (!(albedo[c] >= 0.0 && albedo[c] <= 1.0))
            return vdbs_error_set(err, VDBS_ERR_INPUT, "--fog: ALBEDO must be in [0, 1], got %g",
                                  albedo[c]);
    scene->fog.present = sigma_t > 0.0;
    scene->fog.sigma_t = sigma_t;
    memcpy(scene->fog.albedo, albedo, sizeof albedo);
    return VDBS_OK;
}

/* A VDB baked with inet: its live multiple scattering, created for the file's own lights,
 * quality and inet options (its vdbscatter_scene) with the viewer's medium, so that converged
 * it is the baked ms; active at once when the viewer's lights or medium are others. */
static vdbs_status open_live(viewer *v, const view_args *a, vdbs_error *err)
{
    v->inet_sweeps = (int)a->inet_sweeps;
    if (v->in.mode != VDBS_RENDER_BAKED || strcmp(v->in.baked_method, "inet") != 0 ||
        a->inet_sweeps <= 0 || !vdbs_lit_grids_have_ms(&v->in.ms))
        return VDBS_OK;
    /* The metadata, and the inet state's grids when a --keep-state bake wrote them. */
    vdbio_lit *lit = NULL;
    vdbs_status st = vdbio_lit_open_prefix(v->input, VDBS_INET_STATE_PREFIX, &lit, err);
    if (st != VDBS_OK)
        return st;
    vdbs_scene *baked = malloc(sizeof *baked);
    const char *meta = vdbio_lit_meta(lit, "vdbscatter_scene");
    if (!baked)
        st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for a scene");
    else if (!meta)
        st = vdbs_error_set(err, VDBS_ERR_INPUT, "%s: no vdbscatter_scene metadata", v->input);
    else
        st = vdbs_scene_parse(meta, NULL, baked, err);
    if (st == VDBS_OK) {
        baked->density_scale = v->in.scene->density_scale;
        memcpy(baked->albedo, v->in.scene->albedo, sizeof baked->albedo);
        baked->g = v->in.scene->g;
        vdbs_inet_live_desc d = {0};
        d.volume = &v->in.volume;
        d.scene = baked;
        d.quality = baked->quality;
        d.runner = v->runner;
        d.state = lit;
        d.state_path = v->input;
        st = vdbs_inet_live_create(&d, &v->live, err);
    }
    vdbio_lit_close(lit);
    free(baked);
    const size_t n = 3 * v->in.volume.coord_count;
    if (st == VDBS_OK) {
        v->live_ms = malloc(sizeof *v->live_ms * (n ? n : 1));
        for (int c = 0; c < 3; ++c)
            v->live_l1[c] = malloc(sizeof *v->live_l1[c] * (n ? n : 1));
        if (!v->live_ms || !v->live_l1[0] || !v->live_l1[1] || !v->live_l1[2])
            st = vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory for the live ms");
    }
    const unsigned changes = VDBS_SCENE_SET_LIGHTS | VDBS_SCENE_FROM_FILE |
                             VDBS_SCENE_SET_DENSITY_SCALE | VDBS_SCENE_SET_ALBEDO |
                             VDBS_SCENE_SET_G;
    if (st == VDBS_OK && (a->desc.scene_set & changes))
        st = live_relight(v, err);
    return st;
}

/* Everything up to the first frame; on failure the caller frees what was made. */
static vdbs_status viewer_open(viewer *v, const view_args *a, GLFWwindow **window, vdbs_error *err)
{
    vdbs_status st = vdbs_render_open(&a->desc, &v->in, err);
    if (st != VDBS_OK)
        return st;
    if (v->in.mode != VDBS_RENDER_BAKED && !a->quiet)
        fprintf(stderr, PROGRAM ": %s is a density VDB: showing single scattering only\n",
                v->input);
    v->size = v->in.camera;
    view_orbit_from_camera(&v->in.camera, &v->orbit);
    v->orbit_home = v->orbit;
    volume_centre(&v->in.volume, v->centre);
    v->march = v->in.march;
    /* Occluders' surfaces are lit through swept light grids (the stored depths are the
     * render kernel's only), so a scene with occluders sweeps as before. */
    if (v->in.scene->occluder_count > 0)
        v->march.stored_depths = 0;
    v->march.s1_march = a->desc.s1_march;
    if (a->desc.s1_oversample > 0) /* else the quality's, as render */
        v->march.s1_oversample = a->desc.s1_oversample;
    v->exposure = a->exposure;
    v->interleave = (int)a->interleave;
    v->interleave_on = !a->no_interleave;
    v->step_scale = 1.0f;
    v->show_single = v->show_multiple = 1;

    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit())
        return vdbs_error_set(err, VDBS_ERR_GPU, "no window system (is DISPLAY set? try xvfb-run)");
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, a->screenshot ? GLFW_FALSE : GLFW_TRUE);
    *window = glfwCreateWindow(v->size.width, v->size.height, PROGRAM, NULL, NULL);
    if (!*window)
        return vdbs_error_set(err, VDBS_ERR_GPU, "no OpenGL 4.3 core window");
    glfwMakeContextCurrent(*window);
    glfwSwapInterval(0);
    vdbs_runner_desc rd = {.backend = a->backend, .current_context = 1};
    if ((st = vdbs_runner_create(&rd, &v->runner, err)) != VDBS_OK)
        return st;
    if ((st = view_display_init(&v->display, err)) != VDBS_OK)
        return st;
    if ((st = vdbs_image_alloc(&v->image, v->size.width, v->size.height, 0, err)) != VDBS_OK)
        return st;
    if ((st = vdbs_march_session_create(v->runner, &v->in.volume,
                                        v->in.mode == VDBS_RENDER_BAKED ? &v->in.ms : NULL,
                                        v->in.scene, &v->march, &v->session, err)) != VDBS_OK)
        return st;
    if ((st = open_live(v, a, err)) != VDBS_OK)
        return st;
    return open_occluders_and_fog(v, err);
}

static void viewer_close(viewer *v, GLFWwindow *window)
{
    if (v->bake.running) {
        pthread_join(v->bake.thread, NULL);
        free(v->bake.scene);
        remove(v->bake.output);
    }
    vdbs_march_session_destroy(v->session);
    vdbs_inet_live_destroy(v->live);
    free(v->live_ms);
    for (int c = 0; c < 3; ++c)
        free(v->live_l1[c]);
    vdbs_image_free(&v->image);
    vdbs_shadow_table_free(&v->shadows);
    vdbs_fog_free(&v->fog);
    free(v->backdrop);
    if (window) {
        view_occluders_free(&v->occluders);
        view_display_free(&v->display);
        vdbs_runner_destroy(v->runner);
        glfwDestroyWindow(window);
    }
    glfwTerminate();
    vdbs_render_input_free(&v->in);
}

static vdbs_status run_screenshot(viewer *v, GLFWwindow *window, const view_args *a,
                                  vdbs_error *err)
{
    vdbs_status st = VDBS_OK;
    /* The picture of the re-baked lighting: wait for it. */
    if (a->rebake && (st = finish_rebake(v, 1, err)) != VDBS_OK)
        return st;
    double first_ms = 0.0, rest_ms = 0.0;
    for (long f = 0; f < a->warmup && st == VDBS_OK; ++f) {
        st = draw_frame(v, 0, err);
        /* The first frame uploads the resident grids; the others are what a user sees. */
        if (f == 0)
            first_ms = v->frame_ms;
        else
            rest_ms += v->frame_ms;
        int fw = 0, fh = 0;
        glfwGetFramebufferSize(window, &fw, &fh);
        if (st == VDBS_OK)
            view_display_draw(&v->display, &v->image, v->exposure, fw, fh);
        glfwSwapBuffers(window);
        glfwPollEvents();
    }
    /* The picture on screen, as floats: the EXR compares with `render`'s. */
    if (st == VDBS_OK)
        st = vdbs_image_write(a->screenshot, &v->image, v->exposure, err);
    double mean_ms = a->warmup > 1 ? rest_ms / (double)(a->warmup - 1) : first_ms;
    if (st == VDBS_OK && a->json) {
        printf("{\"width\": %d, \"height\": %d, \"frames\": %ld, \"open_ms\": %.3f, "
               "\"first_frame_ms\": %.3f, \"frame_ms\": %.3f, \"s1\": \"%s\", "
               "\"backend\": \"%s\", \"renderer\": \"%s\", "
               "\"interleave\": %d, \"occluders\": %d, \"fog\": %d, \"inet_sweeps\": %d, "
               "\"ms_live\": %d, \"live_sweeps\": %d, \"live_change\": %.6g, "
               "\"live_converged\": %d, \"live_update_ms\": %.3f, \"inet_start\": \"%s\", "
               "\"inet_open_sweeps\": %d}\n",
               v->image.width, v->image.height, a->warmup, v->open_ms, first_ms, mean_ms,
               v->march.stored_depths ? "stored"
               : v->march.s1_march    ? "march"
                                      : "grid",
               vdbs_runner_backend_name(v->runner), vdbs_runner_device(v->runner),
               v->interleave_on ? v->interleave : 1, v->occluders.count, v->march_fog.fog != NULL,
               v->inet_sweeps, v->live_active, v->live_status.sweeps, v->live_status.change,
               v->live_status.converged, v->live_update_ms,
               !v->live                                    ? "none"
               : vdbs_inet_live_opened(v->live).from_state ? "state"
                                                           : "cold",
               v->live ? vdbs_inet_live_opened(v->live).sweeps : 0);
    } else if (st == VDBS_OK && !a->quiet) {
        fprintf(stderr, PROGRAM ": %dx%d in %.1f ms a frame (first %.1f ms) on %s -> %s\n",
                v->image.width, v->image.height, mean_ms, first_ms, vdbs_runner_device(v->runner),
                a->screenshot);
    }
    return st;
}

static vdbs_status run_interactive(viewer *v, GLFWwindow *window, vdbs_error *err)
{
    glfwSetWindowUserPointer(window, v);
    glfwSetKeyCallback(window, on_key);
    glfwSetMouseButtonCallback(window, on_button);
    glfwSetCursorPosCallback(window, on_cursor);
    glfwSetScrollCallback(window, on_scroll);
    fputs(keys_help, stdout);
    fflush(stdout);
    v->dirty = 1;
    int refined = 0;
    while (!glfwWindowShouldClose(window)) {
        vdbs_error rebake_err;
        finish_rebake(v, 0, &rebake_err); /* a failure shows in the title */
        int moving = now() - v->last_input < MOVING_SECONDS || v->dragging;
        /* The live multiple scattering converging: a frame (and its sweeps) each turn. */
        const int live = v->live_active && !v->live_status.converged;
        if (live)
            v->dirty = 1;
        /* Still after moving: one more frame at the full step. */
        if (!moving && !refined)
            v->dirty = 1;
        if (v->dirty) {
            vdbs_status st = draw_frame(v, moving, err);
            if (st != VDBS_OK)
                return st;
            v->dirty = 0;
            refined = !moving;
        }
        int fw = 0, fh = 0;
        glfwGetFramebufferSize(window, &fw, &fh);
        view_display_draw(&v->display, &v->image, v->exposure, fw, fh);
        set_title(window, v);
        glfwSwapBuffers(window);
        /* Idle without spinning; wake for the re-bake and the refinement. */
        if (live)
            glfwPollEvents();
        else if (v->bake.running || moving)
            glfwWaitEventsTimeout(0.05);
        else
            glfwWaitEvents();
    }
    return VDBS_OK;
}

int main(int argc, char **argv)
{
    vdbs_options_args args;
    vdbs_error err;
    vdbs_status st;
    if (vdbs_options_parse(argc - 1, argv + 1, options, &args, &err) != VDBS_OK)
        return fail(VDBS_ERR_INPUT, err.message);
    if (args.help) {
        fputs(help, stdout);
        fputs("\n", stdout);
        fputs(keys_help, stdout);
        return VDBS_EXIT_OK;
    }
    if (args.positional_count > 1)
        return fail(VDBS_ERR_INPUT, "expected one input VDB");
    view_args a;
    memset(&a, 0, sizeof a);
    if ((st = parse_view_args(&args, &a, &err)) != VDBS_OK)
        return fail(st, err.message);
    vdbs_scene *scene = malloc(sizeof *scene);
    if (!scene)
        return fail(VDBS_ERR_NOMEM, "out of memory");
    if ((st = vdbs_options_build_scene(&args, scene, 1, &err)) != VDBS_OK) {
        free(scene);
        return fail(st, err.message);
    }
    const char *fog_flag = vdbs_options_value(&args, "--fog");
    if (fog_flag && (st = parse_fog(fog_flag, scene, &err)) != VDBS_OK) {
        free(scene);
        return fail(st, err.message);
    }
    /* A scene naming a missing or malformed OBJ fails here, before any window. */
    if ((st = vdbs_occluders_check(scene, &err)) != VDBS_OK) {
        free(scene);
        return fail(st, err.message);
    }
    viewer *v = calloc(1, sizeof *v);
    if (!v) {
        free(scene);
        return fail(VDBS_ERR_NOMEM, "out of memory");
    }
    v->input = args.positional_count ? args.positional[0] : scene->volume_file;
    a.desc.input = v->input;
    a.desc.scene = scene;
    a.desc.scene_set = vdbs_options_scene_flags(&args);
    /* Scene flags or a scene file on a lit VDB relight it, with its multiple scattering shown
     * as stale (b re-bakes); without them the first frame comes from its stored depths. */
    a.desc.relight = (a.desc.scene_set & ~(unsigned)VDBS_SCENE_SET_QUALITY) != 0;
    a.desc.warn = vdbs_command_warn;
    a.desc.warn_user = &a.quiet;
    if (a.screenshot && (st = vdbio_check_output(a.screenshot, v->input, &err)) != VDBS_OK) {
        free(v);
        free(scene);
        return fail(st, err.message);
    }
    GLFWwindow *window = NULL;
    double t_open = now();
    st = viewer_open(v, &a, &window, &err);
    v->open_ms = 1e3 * (now() - t_open);
    /* Light flags on a lit VDB: its multiple scattering belongs to the baked lights. */
    if (st == VDBS_OK)
        v->ms_stale = v->in.mode == VDBS_RENDER_BAKED && !v->live &&
                      (a.desc.scene_set & VDBS_SCENE_SET_LIGHTS);
    if (st == VDBS_OK && a.rebake)
        start_rebake(v);
    if (st == VDBS_OK)
        st = a.screenshot ? run_screenshot(v, window, &a, &err) : run_interactive(v, window, &err);
    viewer_close(v, window);
    free(v);
    free(scene);
    return st == VDBS_OK ? VDBS_EXIT_OK : fail(st, err.message);
}
