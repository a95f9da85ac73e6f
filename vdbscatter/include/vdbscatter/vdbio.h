/* OpenVDB file I/O behind a C API. vdbio.cpp, one of two C++ bridges (exrmap.cpp reads
 * OpenEXR), implements this header over OpenVDB and NanoVDB (OpenToNanoVDB, its file IO). */
#ifndef VDBSCATTER_VDBIO_H
#define VDBSCATTER_VDBIO_H

#include <stddef.h>
#include <stdint.h>

#include "vdbscatter/cancel.h"
#include "vdbscatter/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Affine index-to-world map, row-major 3x4: world[r] = sum_c m[r][c] * ijk[c] + m[r][3].
 * Voxel (i,j,k) has its centre at index-space point (i,j,k). */
typedef struct vdbio_transform {
    double m[3][4];
} vdbio_transform;

/* One grid of a file, as listed by vdbio_list_grids. */
typedef struct vdbio_grid_summary {
    char name[256];
    char value_type[32]; /* OpenVDB's type name: "float", "double", "int32", "vec3s", ... */
    char grid_class[32]; /* "fog volume", "level set", "unknown", ... */
    int is_affine;       /* 0 for frustum or other non-linear maps */
    vdbio_transform transform;
    double voxel_size[3];   /* world length of the three index axes */
    int bbox_min[3];        /* active bounding box in index space (inclusive); */
    int bbox_max[3];        /* min 0 and max -1 when the grid is empty */
    uint64_t active_voxels; /* active voxels, counting voxels inside active tiles */
    uint64_t active_tiles;
    double background; /* scalar grids (float, double, int32, int64, bool); 0 otherwise */
    double value_min;  /* over active values of float/double grids; 0 when empty or otherwise */
    double value_max;
} vdbio_grid_summary;

/* A string item of a file's metadata, read from its header alone (no grid is loaded):
 * *value malloc'd, or NULL when the file has no such string. Errors as vdbio_list_grids. */
vdbs_status vdbio_file_meta(const char *path, const char *key, char **value, vdbs_error *err);

/* The most worker threads OpenVDB's TBB pool may use from now on, process-wide; 0 lifts the
 * limit (--threads). */
void vdbio_thread_limit(int threads);

/* Lists every grid of a file, in file order (duplicate names appear as often as they
 * occur). *grids is malloc'd (free with free()).
 * Errors: missing file, not a VDB, truncated or unreadable file. */
vdbs_status vdbio_list_grids(const char *path, vdbio_grid_summary **grids, int *count,
                             vdbs_error *err);

typedef struct vdbio_read_options {
    /* Grid name; NULL means "density", or the only float grid of the file whatever its name. */
    const char *grid_name;
    /* Which of several grids sharing grid_name (0 = first); from "--grid NAME@INDEX".
     * The duplicate-name warning is given only for index 0; out of range is an error. */
    int grid_index;
    /* Convert a level set (signed distance) into a fog volume instead of refusing it
     * (openvdb::tools::sdfToFogVolume); ignored with a warning for a fog volume. */
    int from_levelset;
    vdbs_warn_fn warn; /* may be NULL */
    void *warn_user;
} vdbio_read_options;

/* A density grid held in memory, ready for baking. Opaque. */
typedef struct vdbio_density vdbio_density;

typedef struct vdbio_density_info {
    char name[256];       /* grid name; "NAME@N" when several grids share the name */
    char source_type[32]; /* type in the file: "float" or "double" */
    vdbio_transform transform;
    double voxel_size[3];
    int bbox_min[3];        /* active bounding box, index space, inclusive; */
    int bbox_max[3];        /* min 0 and max -1 for an empty grid (only from_dense makes one) */
    uint64_t active_voxels; /* including voxels inside active tiles */
    uint64_t active_tiles;
    float value_min; /* over active values */
    float value_max;
    double original_background; /* background as found in the file (now reset to 0) */
} vdbio_density_info;

/* Reads a float (or double, converted to float) density grid. On return every
 * inactive value and the background are 0. Errors (VDBS_ERR_INPUT, message naming
 * the file and the problem): missing file, not a VDB, truncated file, no such grid
 * (the message lists the grids present), non-float grid, empty grid, level set
 * (unless from_levelset), NaN/Inf or negative active values (count and first
 * index/world position), a non-affine (frustum) transform.
 * Warnings: duplicate grid names, a non-zero background reset to 0. */
vdbs_status vdbio_density_read(const char *path, const vdbio_read_options *options,
                               vdbio_density **out, vdbs_error *err);

/* Builds a density grid from a dense array values[(k * dims[1] + j) * dims[0] + i]
 * whose element (0,0,0) is index (origin[0], origin[1], origin[2]). Values <= 0
 * are inactive (stored as 0). Used by the procedural samples and the tests.
 * origin NULL means (0,0,0), transform NULL the identity, name NULL "density".
 * All values <= 0 give an empty grid (not an error). NaN/Inf values and a
 * singular transform are VDBS_ERR_INPUT; NULL arguments and dims <= 0 are
 * VDBS_ERR_INTERNAL. */
vdbs_status vdbio_density_from_dense(const float *values, const int dims[3], const int origin[3],
                                     const vdbio_transform *transform, const char *name,
                                     vdbio_density **out, vdbs_error *err);

void vdbio_density_free(vdbio_density *density);

const vdbio_density_info *vdbio_density_get_info(const vdbio_density *density);

/* Value at an index coordinate (0 where inactive). For tests and samplers;
 * thread-safe (uncached tree lookup). */
float vdbio_density_value(const vdbio_density *density, const int ijk[3]);

/* NanoVDB float grid of the density (one grid in the buffer), malloc'd; free with free().
 * The buffer is 32-byte aligned; *size is rounded up to a multiple of 32 (zero padding). */
vdbs_status vdbio_density_to_nanovdb(const vdbio_density *density, void **buffer, size_t *size,
                                     vdbs_error *err);

/* Index coordinates of the output voxels: the active region (tiles voxelised)
 * dilated by `dilation` voxels in all 26 directions; xyz triples, malloc'd,
 * in OpenVDB's tree order (leaf by leaf), so nearby voxels are nearby in the list. */
vdbs_status vdbio_density_output_coords(const vdbio_density *density, int dilation,
                                        int32_t **coords, size_t *count, vdbs_error *err);

/* A vec3s grid whose values are given for a list of coordinates. */
typedef struct vdbio_vec3_grid {
    const char *name;
    const float *values; /* 3 floats per coordinate, aligned with vdbio_write_request.coords */
} vdbio_vec3_grid;

/* A float grid: on the request's coordinates and the density's transform, or on its own. */
typedef struct vdbio_float_grid {
    const char *name;
    const float *values;   /* 1 float per coordinate */
    const int32_t *coords; /* its own voxels (3 ints each); NULL: the request's coords */
    size_t coord_count;
    const vdbio_transform *transform; /* its own index-to-world map; NULL: the density's */
    /* 1: saved as half floats whatever the request's `half`; values are rounded to half
     * before the write, so the file reads back exactly what the caller is told it holds. */
    int half;
} vdbio_float_grid;

/* String metadata (file-level unless noted). Values are written as OpenVDB string metadata. */
typedef struct vdbio_meta {
    const char *key;
    const char *value;
} vdbio_meta;

typedef struct vdbio_write_request {
    const vdbio_density *density; /* written as grid "density" with the density's transform */
    const int32_t *coords;        /* output voxels for the vec3 grids (3 ints each) */
    size_t coord_count;
    const vdbio_vec3_grid *vec3_grids;
    int vec3_grid_count;
    const vdbio_float_grid *float_grids; /* after the vec3 grids */
    int float_grid_count;
    const vdbio_meta *file_meta; /* written on the file and on every grid */
    int file_meta_count;
    int half; /* store as half floats; values beyond 65504 are clamped with a warning */
    vdbs_warn_fn warn;
    void *warn_user;
    /* Polled before the temporary file is made and again once it is written and synced,
     * just before the rename: when set, the temporary file is removed, the old output stays
     * and the write returns VDBS_ERR_CANCELLED. NULL: never. */
    const vdbs_cancel *cancel;
} vdbio_write_request;

/* The output checks vdbio_write makes first, for callers that want to fail before long
 * work: VDBS_ERR_INPUT when path is empty, the input file, a directory, or in a folder
 * that does not exist or is not writable (VDBS_ERR_INTERNAL when it is NULL). */
vdbs_status vdbio_check_output(const char *path, const char *input_path, vdbs_error *err);

/* Writes all grids to `path` through a temporary file in the same directory
 * (".NAME.tmp.PID") that is fsync'd and renamed on success and removed on failure.
 * The format follows the name: ".vdb" OpenVDB; ".nvdb" NanoVDB (uncompressed, NanoVDB's
 * writer; float grids as Float, vec3s as Vec3f, each with its name and map, values as the
 * .vdb would read back, half-rounded where it stores halves), with the file metadata as a
 * JSON object in "PATH.json", written and synced the same way and renamed just before the
 * .nvdb, so that a cancel or failure leaves neither new file; any other name is
 * VDBS_ERR_INPUT (after vdbio_check_output's checks). The .nvdb's sidecar equal to
 * `input_path` is refused as well;
 * refuses (VDBS_ERR_INPUT) a path that is the same file as `input_path` (when not
 * NULL and existing; compared by realpath and by device/inode). vec3 grids are
 * marked as non-fog ("unknown" class) with vector type "invariant". File metadata
 * gets "creator" = "vdbscatter" unless file_meta sets it; grids get every file_meta
 * entry except OpenVDB's reserved keys (name, class, value_type, file_*, ...).
 * Output errors are VDBS_ERR_IO. */
vdbs_status vdbio_write(const char *path, const char *input_path,
                        const vdbio_write_request *request, vdbs_error *err);

/* What vdbio_write holds at its peak beside the caller's arrays: it builds the OpenVDB tree
 * of every grid before it writes any. nodes: the nodes of each level the output voxels touch
 * (vdbs_volume_node_counts: leaves of 8^3, then 128^3 and 4096^3 internal nodes, whose child
 * tables are whole once one voxel is on), each in every one of vec3_grids grids;
 * float_samples: the voxels of float_grids grids of their own (stored depths: half-full
 * leaves, one top node each and an inner node per 2^20 samples). */
int64_t vdbio_write_bytes(const int64_t nodes[3], int vec3_grids, int float_grids,
                          int64_t float_samples);

/* A lit VDB opened for reading back (tests, `render --mode baked`): every grid of
 * the file is loaded; lookups go through per-thread cached accessors, so one
 * vdbio_lit may be shared by many threads. With duplicate names the first grid wins. */
typedef struct vdbio_lit vdbio_lit;
vdbs_status vdbio_lit_open(const char *path, vdbio_lit **out, vdbs_error *err);
/* The same with only the grids whose names start with `prefix` (a solver's state: reading a
 * warm start then costs its own grids, not the whole lit VDB); the metadata is all there. */
vdbs_status vdbio_lit_open_prefix(const char *path, const char *prefix, vdbio_lit **out,
                                  vdbs_error *err);
int vdbio_lit_has_grid(const vdbio_lit *lit, const char *name);
/* Value of a vec3s grid at index coordinates ((0,0,0) where inactive). */
vdbs_status vdbio_lit_vec3(const vdbio_lit *lit, const char *grid, const int ijk[3], float out[3],
                           vdbs_error *err);
/* The same at `count` voxels (3 ints each) into out (3 floats each): one lookup of the grid
 * and one accessor for all of them. */
vdbs_status vdbio_lit_vec3_many(const vdbio_lit *lit, const char *grid, const int *ijk,
                                size_t count, float *out, vdbs_error *err);
/* Value of a float grid at index coordinates (0 where inactive). */
vdbs_status vdbio_lit_float(const vdbio_lit *lit, const char *grid, const int ijk[3], float *out,
                            vdbs_error *err);
/* Copies a float or vec3s grid's values over the index box [origin, origin + size) into values
 * (x varying fastest; 1 or 3 floats a voxel), as the tree holds them, active or not: one
 * threaded pass over the tree. Errors: no such grid, another type (VDBS_ERR_INPUT). */
vdbs_status vdbio_lit_dense(const vdbio_lit *lit, const char *grid, const int origin[3],
                            const int size[3], float *values, vdbs_error *err);
/* NanoVDB Vec3f grid of a vec3s grid of the file (one grid in the buffer), with the same
 * allocation convention as vdbio_density_to_nanovdb (32-byte aligned, free with free()).
 * Errors: no such grid, not a vec3s grid (VDBS_ERR_INPUT). */
vdbs_status vdbio_lit_vec3_nanovdb(const vdbio_lit *lit, const char *grid, void **buffer,
                                   size_t *size, vdbs_error *err);
/* The same for a float grid of the file (a NanoVDB float grid). */
vdbs_status vdbio_lit_float_nanovdb(const vdbio_lit *lit, const char *grid, void **buffer,
                                    size_t *size, vdbs_error *err);
/* Transform of a grid of the file. */
vdbs_status vdbio_lit_transform(const vdbio_lit *lit, const char *grid, vdbio_transform *out,
                                vdbs_error *err);
/* File-level string metadata value, or NULL. */
const char *vdbio_lit_meta(const vdbio_lit *lit, const char *key);
void vdbio_lit_close(vdbio_lit *lit);

/* For tests only: writes one grid whose every element of the dense array (same
 * layout as vdbio_density_from_dense) is active with its raw value, including
 * negatives and NaN, with the given background, straight to `path`.
 * values and dims NULL write a file without grids. */
enum {
    VDBIO_DEBUG_LEVEL_SET = 1, /* grid class "level set" instead of "fog volume" */
    VDBIO_DEBUG_FRUSTUM = 2,   /* a frustum (non-linear) transform */
    VDBIO_DEBUG_DOUBLE = 4     /* store as a double grid */
};
vdbs_status vdbio_debug_write_float_grid(const char *path, const char *grid_name,
                                         const float *values, const int dims[3],
                                         const int origin[3], float background, int flags,
                                         vdbs_error *err);

#ifdef __cplusplus
}
#endif

#endif
