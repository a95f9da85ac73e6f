/* NanoVDB output of vdbio_write: one request written as .vdb and as .nvdb must give the
 * same grids. The .vdb read back by OpenVDB is the oracle; the .nvdb is read by NanoVDB's
 * own reader (nanovdb::io::readGrids) and compared grid by grid: name, type, transform,
 * active voxels and bit-exact values; the .nvdb.json sidecar must equal the .vdb's file
 * metadata key for key. C++ only to reach the two libraries' readers. */
#include <cjson/cJSON.h>
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nanovdb/util/IO.h>
#include <openvdb/openvdb.h>

#include "vdbscatter/vdbio.h"

/* After the libraries' headers: cmocka's macros (fail, skip) would rewrite their code. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

extern "C" { /* cmocka.h has no C++ guard */
#include <cmocka.h>
}

extern "C" const char *test_tmp_path(const char *file);

namespace
{

/* A private folder under the test temp folder, so that the temp-file checks do not see
 * other tests' files when ctest runs them in parallel. */
std::string tmp_dir()
{
    const std::string dir = test_tmp_path("nvdb");
    mkdir(dir.c_str(), 0755);
    return dir;
}

std::string in_tmp(const char *name)
{
    return tmp_dir() + "/" + name;
}

bool exists(const std::string &path)
{
    struct stat st;
    return stat(path.c_str(), &st) == 0;
}

int temp_files_left()
{
    int n = 0;
    DIR *d = opendir(tmp_dir().c_str());
    assert_non_null(d);
    while (struct dirent *e = readdir(d))
        n += strstr(e->d_name, ".tmp.") != nullptr;
    closedir(d);
    return n;
}

std::string slurp(const std::string &path)
{
    std::ifstream is(path, std::ios::binary);
    std::stringstream ss;
    ss << is.rdbuf();
    return ss.str();
}

/* Deterministic values whose low mantissa bits are set, so that a float-to-half or any other
 * rounding on the way would show. */
float value_at(int i, int salt)
{
    const uint32_t h = (uint32_t)i * 2654435761u ^ (uint32_t)salt * 40503u;
    return 0.0137f + (float)(h % 100003u) * 1.3e-5f + 1e-7f * (float)(h % 7u);
}

/* Rotation about an oblique axis times a non-uniform scale plus an offset. */
vdbio_transform rotated(double angle, double sx, double sy, double sz, double tx, double ty,
                        double tz)
{
    double ax = 0.48, ay = 0.6, az = 0.64; /* unit axis */
    double c = cos(angle), s = sin(angle), t = 1.0 - c;
    double r[3][3] = {{t * ax * ax + c, t * ax * ay - s * az, t * ax * az + s * ay},
                      {t * ax * ay + s * az, t * ay * ay + c, t * ay * az - s * ax},
                      {t * ax * az - s * ay, t * ay * az + s * ax, t * az * az + c}};
    const double scale[3] = {sx, sy, sz};
    vdbio_transform out;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
            out.m[i][j] = r[i][j] * scale[j];
    }
    out.m[0][3] = tx;
    out.m[1][3] = ty;
    out.m[2][3] = tz;
    return out;
}

/* Everything a request points at, kept alive for the writes. */
struct Request {
    vdbio_density *density = nullptr;
    int32_t *coords = nullptr;
    size_t count = 0;
    std::vector<float> vec[2], flt_a, flt_b, flt_sky;
    std::vector<int32_t> own_coords;
    vdbio_transform own_transform, density_transform;
    vdbio_vec3_grid vec3[2];
    vdbio_float_grid floats[3];
    std::vector<vdbio_meta> meta;
    vdbio_write_request req;
    int warnings = 0;

    Request()
    {
        const int dims[3] = {9, 7, 6}, origin[3] = {-4, 2, -3};
        std::vector<float> dense((size_t)dims[0] * dims[1] * dims[2]);
        for (size_t i = 0; i < dense.size(); ++i)
            dense[i] = (i % 5 == 0) ? 0.0f : value_at((int)i, 1) * 3.0f;
        dense[17] = 1.0e5f; /* beyond the half range: clamped in the half run */
        density_transform = rotated(0.7, 0.05, 0.06, 0.045, 1.25, -0.5, 3.0);
        vdbs_error err;
        if (vdbio_density_from_dense(dense.data(), dims, origin, &density_transform, "smoke",
                                     &density, &err) != VDBS_OK)
            fail_msg("%s", err.message);
        if (vdbio_density_output_coords(density, 1, &coords, &count, &err) != VDBS_OK)
            fail_msg("%s", err.message);
        for (int g = 0; g < 2; ++g) {
            vec[g].resize(3 * count);
            for (size_t i = 0; i < 3 * count; ++i)
                vec[g][i] = value_at((int)i, 10 + g);
        }
        flt_a.resize(count);
        flt_sky.resize(count);
        for (size_t i = 0; i < count; ++i) {
            flt_a[i] = value_at((int)i, 20) * 7.0f;
            flt_sky[i] = value_at((int)i, 30) * 11.0f;
        }
        flt_sky[3] = 70000.0f; /* clamped to 65504 */
        /* A light grid of its own: a 5x4x3 block of texels at negative indices. */
        for (int k = 0; k < 3; ++k) {
            for (int j = 0; j < 4; ++j) {
                for (int i = 0; i < 5; ++i) {
                    own_coords.insert(own_coords.end(), {i - 7, j - 2, k + 40});
                    flt_b.push_back(value_at(i + 5 * j + 20 * k, 40));
                }
            }
        }
        own_transform = rotated(-1.1, 0.25, 0.125, 0.3, -2.0, 7.5, 0.25);
        vec3[0] = {"radiance", vec[0].data()};
        vec3[1] = {"ms", vec[1].data()};
        floats[0] = {"light_depth_000", flt_a.data(), nullptr, 0, nullptr, 0};
        floats[1] = {"light_depth_001",     flt_b.data(),   own_coords.data(),
                     own_coords.size() / 3, &own_transform, 0};
        floats[2] = {"sky_depth_0000", flt_sky.data(), nullptr, 0, nullptr, 1};
        meta = {{"vdbscatter_format", "2"},
                {"vdbscatter_scene", "{\"volume\": {\"albedo\": [0.5, 0.5, 0.5]},\n\t\"a\\b\": 1}"},
                {"vdbscatter_lights", "[{\"type\": \"sun\", \"name\": \"caf\xc3\xa9\x01\"}]"},
                {"vdbscatter_g", "0.25"}};
        memset(&req, 0, sizeof req);
        req.density = density;
        req.coords = coords;
        req.coord_count = count;
        req.vec3_grids = vec3;
        req.vec3_grid_count = 2;
        req.float_grids = floats;
        req.float_grid_count = 3;
        req.file_meta = meta.data();
        req.file_meta_count = (int)meta.size();
        req.warn = [](void *user, const char *) { ++*static_cast<int *>(user); };
        req.warn_user = &warnings;
    }
    ~Request()
    {
        vdbio_density_free(density);
        free(coords);
    }
};

void write_ok(const std::string &path, const Request &r)
{
    vdbs_error err;
    if (vdbio_write(path.c_str(), nullptr, &r.req, &err) != VDBS_OK)
        fail_msg("%s: %s", path.c_str(), err.message);
}

void near_world(const openvdb::Vec3d &a, const nanovdb::Vec3d &b, const std::string &name)
{
    for (int c = 0; c < 3; ++c) {
        if (!(std::fabs(a[c] - b[c]) <= 1e-12 * std::max(1.0, std::fabs(a[c]))))
            fail_msg("%s: index-to-world %.17g vs %.17g", name.c_str(), a[c], b[c]);
    }
}

/* Every active voxel of the OpenVDB grid (tiles voxelised) is active in the NanoVDB grid
 * with the same bits, and there are no others. Returns the voxel count. */
template <typename OpenGridT, typename NanoValueT>
uint64_t compare_values(const OpenGridT &open, const nanovdb::NanoGrid<NanoValueT> &nano)
{
    auto acc = nano.getAccessor();
    uint64_t n = 0;
    for (auto it = open.cbeginValueOn(); it; ++it) {
        const openvdb::CoordBBox box = it.getBoundingBox();
        const typename OpenGridT::ValueType v = *it;
        for (auto c = box.begin(); c; ++c) {
            const nanovdb::Coord ijk((*c)[0], (*c)[1], (*c)[2]);
            if (!acc.isActive(ijk))
                fail_msg("%s: (%d,%d,%d) active in the .vdb, not in the .nvdb",
                         open.getName().c_str(), ijk[0], ijk[1], ijk[2]);
            const NanoValueT w = acc.getValue(ijk);
            static_assert(sizeof v == sizeof w, "same value layout");
            if (memcmp(&v, &w, sizeof v) != 0)
                fail_msg("%s: value at (%d,%d,%d) differs", open.getName().c_str(), ijk[0], ijk[1],
                         ijk[2]);
            ++n;
        }
    }
    assert_int_equal(n, open.activeVoxelCount());
    assert_int_equal(nano.activeVoxelCount(), n);
    return n;
}

/* The sidecar's object equals the .vdb's file metadata: same keys, same string values. */
void compare_sidecar(const std::string &json_path, const openvdb::MetaMap &meta)
{
    const std::string text = slurp(json_path);
    cJSON *root = cJSON_Parse(text.c_str());
    assert_non_null(root);
    assert_true(cJSON_IsObject(root));
    size_t n = 0;
    for (cJSON *item = root->child; item; item = item->next) {
        ++n;
        assert_true(cJSON_IsString(item));
        openvdb::Metadata::ConstPtr m = meta[item->string];
        if (!m)
            fail_msg("sidecar key %s is not in the .vdb", item->string);
        assert_string_equal(m->typeName().c_str(), "string");
        assert_string_equal(item->valuestring, m->str().c_str());
    }
    assert_int_equal(n, meta.metaCount());
    cJSON_Delete(root);
}

/* Compares the two files grid by grid; returns the grids' voxel counts by name. */
void compare_files(const std::string &vdb, const std::string &nvdb, const Request &r)
{
    openvdb::io::File file(vdb);
    file.open();
    openvdb::GridPtrVecPtr grids = file.getGrids();
    openvdb::MetaMap::Ptr meta = file.getMetadata();
    file.close();
    std::vector<nanovdb::GridHandle<nanovdb::HostBuffer>> handles = nanovdb::io::readGrids(nvdb);
    const char *names[] = {"density",         "radiance",        "ms",
                           "light_depth_000", "light_depth_001", "sky_depth_0000"};
    assert_int_equal(grids->size(), 6);
    assert_int_equal(handles.size(), 6);
    /* OpenVDB lists a file's grids by name; the .nvdb keeps the request's order. */
    auto by_name = [&](const char *name) -> const openvdb::GridBase & {
        for (const openvdb::GridBase::Ptr &p : *grids) {
            if (p->getName() == name)
                return *p;
        }
        fail_msg("%s: not in the .vdb", name);
        return *(*grids)[0];
    };
    for (size_t g = 0; g < grids->size(); ++g) {
        const openvdb::GridBase &open = by_name(names[g]);
        const nanovdb::GridMetaData *md = handles[g].gridMetaData();
        assert_string_equal(open.getName().c_str(), names[g]);
        assert_string_equal(md->shortGridName(), names[g]);
        const openvdb::Vec3d points[] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-7, 3, 41}};
        for (const openvdb::Vec3d &p : points)
            near_world(open.indexToWorld(p), md->map().applyMap(nanovdb::Vec3d(p[0], p[1], p[2])),
                       open.getName());
        uint64_t voxels = 0;
        if (open.valueType() == "float") {
            const nanovdb::NanoGrid<float> *nano = handles[g].grid<float>();
            assert_non_null(nano);
            assert_int_equal((int)nano->gridType(), (int)nanovdb::GridType::Float);
            voxels = compare_values(static_cast<const openvdb::FloatGrid &>(open), *nano);
        } else if (open.valueType() == "vec3s") {
            const nanovdb::NanoGrid<nanovdb::Vec3f> *nano = handles[g].grid<nanovdb::Vec3f>();
            assert_non_null(nano);
            assert_int_equal((int)nano->gridType(), (int)nanovdb::GridType::Vec3f);
            voxels = compare_values(static_cast<const openvdb::Vec3SGrid &>(open), *nano);
        } else {
            fail_msg("%s: unexpected type %s", names[g], open.valueType().c_str());
        }
        /* Not vacuous: each grid holds the voxels the request gave it. */
        const size_t want = g == 0   ? vdbio_density_get_info(r.density)->active_voxels
                            : g == 4 ? r.own_coords.size() / 3
                                     : r.count;
        assert_int_equal(voxels, want);
    }
    /* The own-transform grid really carries its own map (the oracle is the request). */
    const openvdb::Vec3d w = by_name("light_depth_001").indexToWorld(openvdb::Vec3d(2, -1, 5));
    for (int a = 0; a < 3; ++a)
        assert_true(std::fabs(w[a] - (r.own_transform.m[a][0] * 2 - r.own_transform.m[a][1] +
                                      r.own_transform.m[a][2] * 5 + r.own_transform.m[a][3])) <
                    1e-12);
    compare_sidecar(nvdb + ".json", *meta);
}

/* The value NanoVDB holds for the sky grid at the first output voxel. */
float nano_sky_value(const std::string &nvdb, const Request &r)
{
    auto handle = nanovdb::io::readGrid(nvdb, std::string("sky_depth_0000"));
    const nanovdb::NanoGrid<float> *grid = handle.grid<float>();
    assert_non_null(grid);
    return grid->getAccessor().getValue(nanovdb::Coord(r.coords[0], r.coords[1], r.coords[2]));
}

void test_same_grids_as_vdb(void **state)
{
    (void)state;
    openvdb::initialize();
    Request r;
    for (int half = 0; half < 2; ++half) {
        r.req.half = half;
        const std::string vdb = in_tmp(half ? "half.vdb" : "full.vdb");
        const std::string nvdb = in_tmp(half ? "half.nvdb" : "full.nvdb");
        r.warnings = 0;
        write_ok(vdb, r);
        write_ok(nvdb, r);
        /* The clamps are reported for both files alike: one warning each (the sky value;
         * with half also the density's). */
        assert_int_equal(r.warnings, 2);
        compare_files(vdb, nvdb, r);
        /* The sky grid holds half-rounded values in both runs (the .vdb oracle says so too,
         * but check against the arithmetic). */
        const float raw = r.flt_sky[0];
        const float rounded = static_cast<float>(openvdb::math::half(raw));
        assert_true(rounded != raw);
        const float got = nano_sky_value(nvdb, r);
        assert_memory_equal(&got, &rounded, sizeof got);
        unlink(vdb.c_str());
        unlink(nvdb.c_str());
        unlink((nvdb + ".json").c_str());
    }
    assert_int_equal(temp_files_left(), 0);
}

void test_cancel_and_refusals(void **state)
{
    (void)state;
    Request r;
    const std::string nvdb = in_tmp("keep.nvdb"), side = nvdb + ".json";
    vdbs_error err;
    /* A cancel before anything is written leaves neither file. */
    vdbs_cancel flag = 2;
    r.req.cancel = &flag;
    unlink(nvdb.c_str());
    unlink(side.c_str());
    assert_int_equal(vdbio_write(nvdb.c_str(), nullptr, &r.req, &err), VDBS_ERR_CANCELLED);
    assert_false(exists(nvdb));
    assert_false(exists(side));
    assert_int_equal(temp_files_left(), 0);
    /* Over an existing pair, a cancel keeps both old files byte for byte. */
    r.req.cancel = nullptr;
    write_ok(nvdb, r);
    const std::string old_grids = slurp(nvdb), old_side = slurp(side);
    const vdbio_meta marker = {"marker", "new"};
    std::vector<vdbio_meta> more = r.meta;
    more.push_back(marker);
    r.req.file_meta = more.data();
    r.req.file_meta_count = (int)more.size();
    r.req.cancel = &flag;
    assert_int_equal(vdbio_write(nvdb.c_str(), nullptr, &r.req, &err), VDBS_ERR_CANCELLED);
    assert_string_equal(err.message, "interrupted");
    assert_true(slurp(nvdb) == old_grids);
    assert_true(slurp(side) == old_side);
    assert_int_equal(temp_files_left(), 0);
    r.req.cancel = nullptr;
    /* The input file is never the output. */
    assert_int_equal(vdbio_write(nvdb.c_str(), nvdb.c_str(), &r.req, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "input"));
    assert_true(slurp(nvdb) == old_grids);
    /* Nor the sidecar. */
    const std::string other = in_tmp("other.nvdb"), other_side = other + ".json";
    {
        std::ofstream os(other_side);
        os << "input";
    }
    assert_int_equal(vdbio_write(other.c_str(), other_side.c_str(), &r.req, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "input"));
    assert_false(exists(other));
    assert_true(slurp(other_side) == "input");
    unlink(other_side.c_str());
    /* Another suffix is refused before anything is written. */
    const std::string bad = in_tmp("lit.txt");
    assert_int_equal(vdbio_write(bad.c_str(), nullptr, &r.req, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, ".vdb or .nvdb"));
    assert_false(exists(bad));
    /* A .nvdb is not read as a density (render, info): one clear line. */
    vdbio_read_options o;
    memset(&o, 0, sizeof o);
    vdbio_density *d = nullptr;
    assert_int_equal(vdbio_density_read(nvdb.c_str(), &o, &d, &err), VDBS_ERR_INPUT);
    assert_non_null(strstr(err.message, "NanoVDB"));
    assert_null(strchr(err.message, '\n'));
    assert_int_equal(temp_files_left(), 0);
    unlink(nvdb.c_str());
    unlink(side.c_str());
}

} // namespace

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_grids_as_vdb),
        cmocka_unit_test(test_cancel_and_refusals),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
