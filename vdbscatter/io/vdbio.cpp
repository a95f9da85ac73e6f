/* OpenVDB / NanoVDB bridge (with exrmap.cpp for OpenEXR, the library's only C++).
 * Every entry point catches every exception and turns it into a vdbs_error. */
#include "vdbscatter/vdbio.h"
#include "vdbscatter/tempfile.h"

#include "contain_tbb.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/Archive.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/io.h>
#include <openvdb/io/Stream.h>
#include <openvdb/math/Transform.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/Morphology.h>
#include <nanovdb/util/IO.h>
#include <nanovdb/util/OpenToNanoVDB.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

namespace
{

using openvdb::Coord;
using openvdb::FloatGrid;
using openvdb::FloatTree;
using openvdb::GridBase;
using openvdb::Vec3SGrid;
using openvdb::Vec3STree;

const float kHalfMax = 65504.0f;

/* Thrown inside the bridge, caught at the C boundary. */
struct Failure {
    vdbs_status status;
    std::string message;
};

[[noreturn]] void fail(vdbs_status status, const std::string &message)
{
    throw Failure{status, message};
}

std::string format(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char *fmt, ...)
{
    char buf[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    return buf;
}

/* OpenVDB messages about corrupt files can quote kilobytes of garbage read as a
 * string: keep error lines short and on one line (UTF-8 bytes pass through). */
std::string sanitize(const std::string &text, size_t max_len = 160)
{
    std::string out;
    bool space = false;
    for (unsigned char c : text) {
        if (c < 0x20 || c == 0x7f || c == ' ') {
            space = true;
            continue;
        }
        if (space && !out.empty())
            out += ' ';
        space = false;
        out += static_cast<char>(c);
        if (out.size() >= max_len) {
            out += "...";
            break;
        }
    }
    return out;
}

void init_openvdb()
{
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

template <typename F> vdbs_status guarded(vdbs_error *err, F &&body)
{
    try {
        init_openvdb();
        body();
        return VDBS_OK;
    } catch (const Failure &f) {
        return vdbs_error_set(err, f.status, "%s", f.message.c_str());
    } catch (const std::bad_alloc &) {
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "out of memory");
    } catch (const std::exception &e) {
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "OpenVDB: %s", sanitize(e.what()).c_str());
    } catch (...) {
        return vdbs_error_set(err, VDBS_ERR_INTERNAL, "unknown exception in the OpenVDB bridge");
    }
}

void copy_string(char *dst, size_t size, const std::string &src)
{
    snprintf(dst, size, "%s", src.c_str());
}

/* OpenVDB applies its Mat4 to row vectors (translation in row 3); ours is the
 * transposed 3x4 column-vector form. */
vdbio_transform transform_to_c(const openvdb::math::Transform &t)
{
    const openvdb::Mat4d m = t.baseMap()->getAffineMap()->getMat4();
    vdbio_transform out;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            out.m[r][c] = m(c, r);
        out.m[r][3] = m(3, r);
    }
    return out;
}

void voxel_size_of(const vdbio_transform &t, double out[3])
{
    for (int c = 0; c < 3; ++c)
        out[c] = std::sqrt(t.m[0][c] * t.m[0][c] + t.m[1][c] * t.m[1][c] + t.m[2][c] * t.m[2][c]);
}

openvdb::math::Transform::Ptr transform_from_c(const vdbio_transform *t)
{
    if (!t)
        return openvdb::math::Transform::createLinearTransform(1.0);
    openvdb::Mat4d m = openvdb::Mat4d::identity();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) {
            if (!std::isfinite(t->m[r][c]))
                fail(VDBS_ERR_INPUT, "transform has a non-finite entry");
        }
        for (int c = 0; c < 3; ++c)
            m(c, r) = t->m[r][c];
        m(3, r) = t->m[r][3];
    }
    const double det = m.getMat3().det();
    if (!(std::fabs(det) > 0.0) || !std::isfinite(det))
        fail(VDBS_ERR_INPUT, "transform is singular");
    return openvdb::math::Transform::createLinearTransform(m);
}

void bbox_to_c(const openvdb::CoordBBox &box, bool empty, int mn[3], int mx[3])
{
    for (int a = 0; a < 3; ++a) {
        mn[a] = empty ? 0 : box.min()[a];
        mx[a] = empty ? -1 : box.max()[a];
    }
}

std::string coord_str(const Coord &c)
{
    return format("(%d, %d, %d)", c.x(), c.y(), c.z());
}

std::string world_str(const openvdb::math::Transform &t, const Coord &c)
{
    const openvdb::Vec3d w = t.indexToWorld(c);
    return format("(%g, %g, %g)", w.x(), w.y(), w.z());
}

/* Opens an archive for reading: the file must exist, be a regular file and start with the
 * OpenVDB magic number. Returns its size; the stream then throws on every short read. */
uint64_t open_vdb_file(const std::string &file, std::ifstream &is)
{
    struct stat st;
    if (stat(file.c_str(), &st) != 0)
        fail(VDBS_ERR_INPUT,
             format("%s: %s", file.c_str(), errno == ENOENT ? "no such file" : strerror(errno)));
    if (S_ISDIR(st.st_mode))
        fail(VDBS_ERR_INPUT, format("%s: is a directory, not a VDB file", file.c_str()));
    const uint64_t size = static_cast<uint64_t>(st.st_size);
    is.open(file, std::ios::in | std::ios::binary);
    if (!is)
        fail(VDBS_ERR_INPUT, format("%s: cannot open: %s", file.c_str(), strerror(errno)));
    int64_t magic = 0;
    is.read(reinterpret_cast<char *>(&magic), sizeof magic);
    /* A NanoVDB file (a bake's .nvdb) is written, never read: say so rather than "not a VDB". */
    if (is.gcount() == sizeof magic && static_cast<uint64_t>(magic) == NANOVDB_MAGIC_NUMBER)
        fail(VDBS_ERR_INPUT,
             format("%s: a NanoVDB file; only OpenVDB (.vdb) files are read", file.c_str()));
    if (is.gcount() != sizeof magic || magic != openvdb::OPENVDB_MAGIC)
        fail(VDBS_ERR_INPUT,
             format("%s: not an OpenVDB file%s", file.c_str(), size == 0 ? " (empty file)" : ""));
    is.seekg(0);
    is.exceptions(std::ios::failbit | std::ios::badbit | std::ios::eofbit);
    return size;
}

/* An archive file open for reading through Archive's protected API instead of io::File:
 * the stream throws on every short read, so a truncated file is an error instead of
 * garbage, and every failure while reading becomes a Failure that names the file. */
class ArchiveInput : public openvdb::io::Archive
{
  public:
    std::string path;

  protected:
    std::ifstream is_;
    uint64_t size_ = 0;
    openvdb::io::StreamMetadata::Ptr stream_meta_;

    void open_stream(const std::string &file)
    {
        path = file;
        size_ = open_vdb_file(file, is_);
    }

    template <typename F> void guard_io(F &&body)
    {
        try {
            body();
        } catch (const Failure &) {
            throw;
        } catch (const std::ios_base::failure &) {
            const bool eof = is_.eof();
            is_.clear();
            fail(VDBS_ERR_INPUT, format("%s: %s", path.c_str(),
                                        eof ? "truncated file (unexpected end of file)"
                                            : "read error (corrupt or truncated file?)"));
        } catch (const openvdb::LookupError &e) {
            fail(VDBS_ERR_INPUT, format("%s: unsupported or corrupt grid (OpenVDB: %s)",
                                        path.c_str(), sanitize(e.what()).c_str()));
        } catch (const std::bad_alloc &) {
            fail(VDBS_ERR_INPUT,
                 format("%s: corrupt file (absurd sizes) or out of memory", path.c_str()));
        } catch (const std::exception &e) {
            fail(VDBS_ERR_INPUT, format("%s: corrupt or truncated file (OpenVDB: %s)", path.c_str(),
                                        sanitize(e.what()).c_str()));
        }
    }

    /* A string length beyond the end of the file means truncation or garbage;
     * checked before OpenVDB allocates it. */
    void check_string_ahead()
    {
        const uint64_t at = static_cast<uint64_t>(static_cast<std::streamoff>(is_.tellg()));
        uint32_t len = 0;
        is_.read(reinterpret_cast<char *>(&len), sizeof len);
        if (at + sizeof len + len > size_)
            fail(VDBS_ERR_INPUT, format("%s: truncated or corrupt file (grid descriptor at byte "
                                        "%llu runs past the end of the file)",
                                        path.c_str(), static_cast<unsigned long long>(at)));
        is_.seekg(static_cast<std::streamoff>(at));
    }

    /* A metadata map (a count, then per entry its name, its type name and its value, each
     * behind a 32-bit length) whose lengths run past `limit` means truncation or garbage;
     * walked before OpenVDB reads it, which allocates and fills each string first (a
     * corrupt length of 2 GB took seconds to fail). The stream is left where it was. */
    void check_meta_ahead(uint64_t limit, const char *what)
    {
        const std::streamoff start = is_.tellg();
        uint64_t at = static_cast<uint64_t>(start);
        const auto corrupt = [&] {
            fail(VDBS_ERR_INPUT,
                 format("%s: truncated or corrupt file (%s metadata at byte %llu runs past its "
                        "end)",
                        path.c_str(), what, static_cast<unsigned long long>(start)));
        };
        int32_t count = 0;
        if (at + sizeof count > limit)
            corrupt();
        is_.read(reinterpret_cast<char *>(&count), sizeof count);
        at += sizeof count;
        /* Every entry holds at least its three lengths. */
        if (count < 0 || static_cast<uint64_t>(count) * 12u > limit - at)
            corrupt();
        for (int32_t i = 0; i < count; ++i) {
            for (int part = 0; part < 3; ++part) {
                uint32_t len = 0;
                if (at + sizeof len > limit)
                    corrupt();
                is_.read(reinterpret_cast<char *>(&len), sizeof len);
                at += sizeof len;
                if (len > limit - at)
                    corrupt();
                at += len;
                is_.seekg(static_cast<std::streamoff>(at));
            }
        }
        is_.seekg(start);
    }

    /* A grid's compression flags and metadata, checked before Archive::readGrid: the grid
     * spans [gd's grid position, its end), or to the end of the file without offsets. */
    void check_grid_meta_ahead(const openvdb::io::GridDescriptor &gd)
    {
        const std::streamoff start = is_.tellg();
        const uint64_t end = inputHasGridOffsets() ? static_cast<uint64_t>(gd.getEndPos()) : size_;
        if (fileVersion() >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION)
            is_.seekg(start + static_cast<std::streamoff>(sizeof(uint32_t)));
        check_meta_ahead(end, "grid");
        is_.seekg(start);
    }

    /* The archive's header and file metadata; returns the grid count that follows. */
    int32_t read_header(openvdb::MetaMap &file_meta)
    {
        readHeader(is_);
        stream_meta_ = std::make_shared<openvdb::io::StreamMetadata>();
        stream_meta_->setSeekable(inputHasGridOffsets());
        openvdb::io::setStreamMetadataPtr(is_, stream_meta_, /*transfer=*/false);
        setFormatVersion(is_);
        setLibraryVersion(is_);
        setDataCompression(is_);
        check_meta_ahead(size_, "file");
        file_meta.readMeta(is_);
        const int32_t count = readGridCount(is_);
        if (count < 0 || static_cast<uint64_t>(count) > size_)
            fail(VDBS_ERR_INPUT, format("%s: corrupt file (grid count %d)", path.c_str(), count));
        return count;
    }

    /* A grid that would end past the end of the file means truncation. */
    void check_grid_extent(const openvdb::io::GridDescriptor &gd)
    {
        const uint64_t end = static_cast<uint64_t>(gd.getEndPos());
        if (gd.getGridPos() < 0 || gd.getGridPos() > gd.getEndPos() || end > size_)
            fail(VDBS_ERR_INPUT,
                 format("%s: truncated file (grid \"%s\" ends at byte %llu, the file "
                        "has %llu bytes)",
                        path.c_str(), sanitize(gd.gridName(), 80).c_str(),
                        static_cast<unsigned long long>(end),
                        static_cast<unsigned long long>(size_)));
    }
};

/* The grids of an archive, listed in file order while only the chosen ones are loaded. */
class Reader : public ArchiveInput
{
  public:
    struct Entry {
        openvdb::io::GridDescriptor gd;
        GridBase::Ptr grid; /* type, half flag; filled by load() */
        bool loaded = false;
    };

    std::vector<Entry> entries;
    openvdb::MetaMap file_meta;

    void open(const std::string &file, bool load_all)
    {
        open_stream(file);
        guard_io([&] { read_directory(load_all); });
    }

    GridBase::Ptr load(size_t index)
    {
        guard_io([&] { load_entry(index); });
        return entries[index].grid;
    }

  private:
    void read_directory(bool load_all)
    {
        const int32_t count = read_header(file_meta);
        for (int32_t i = 0; i < count; ++i)
            read_descriptor();
        if (load_all)
            load_all_entries();
        connect_instances();
    }

    /* Every grid, read side by side with OpenVDB's own threads (a lit VDB of a 256-ordinate
     * sky holds 260 grids): each range of grids through a stream of its own on the same file.
     * Instances, which need their parents, and files without offsets load in order after. */
    void load_all_entries()
    {
        if (inputHasGridOffsets()) {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, entries.size(), 8),
                              [&](const tbb::blocked_range<size_t> &range) {
                                  Reader side;
                                  side.open_stream(path);
                                  side.guard_io([&] {
                                      openvdb::MetaMap meta;
                                      side.read_header(meta);
                                      for (size_t i = range.begin(); i != range.end(); ++i)
                                          side.read_grid_into(entries[i]);
                                  });
                              });
        }
        for (size_t i = 0; i < entries.size(); ++i)
            load_entry(i);
    }

    /* A grid that is not an instance, from this reader's stream into e (another reader's). */
    void read_grid_into(Entry &e)
    {
        if (e.loaded || e.gd.isInstance())
            return;
        e.gd.seekToGrid(is_);
        check_grid_meta_ahead(e.gd);
        Archive::readGrid(e.grid, e.gd, is_);
        e.loaded = true;
    }

    /* The next grid's descriptor; the grid itself is read now only when the file has no
     * offsets to come back to it. */
    void read_descriptor()
    {
        check_string_ahead();
        Entry e;
        e.grid = e.gd.read(is_);
        if (!e.grid)
            fail(VDBS_ERR_INPUT, format("%s: grid type %s is not supported", path.c_str(),
                                        sanitize(e.gd.gridType(), 60).c_str()));
        if (inputHasGridOffsets()) {
            check_grid_extent(e.gd);
            entries.push_back(e);
            e.gd.seekToEnd(is_);
        } else {
            /* Without offsets the grids can only be read in sequence. */
            check_grid_meta_ahead(e.gd);
            Archive::readGrid(e.grid, e.gd, is_);
            e.loaded = true;
            entries.push_back(e);
        }
    }

    void load_entry(size_t index, size_t depth = 0)
    {
        Entry &e = entries[index];
        if (e.loaded)
            return;
        if (e.gd.isInstance()) {
            /* A corrupt file could make a grid its own (indirect) parent. */
            if (depth > entries.size())
                fail(VDBS_ERR_INPUT,
                     format("%s: corrupt file (grid instances form a cycle)", path.c_str()));
            bool found = false;
            for (size_t i = 0; i < entries.size(); ++i) {
                if (entries[i].gd.uniqueName() == e.gd.instanceParentName()) {
                    load_entry(i, depth + 1);
                    found = true;
                }
            }
            if (!found)
                fail(VDBS_ERR_INPUT, format("%s: grid \"%s\" is an instance of a missing grid",
                                            path.c_str(), sanitize(e.gd.gridName(), 80).c_str()));
        }
        e.gd.seekToGrid(is_);
        check_grid_meta_ahead(e.gd);
        Archive::readGrid(e.grid, e.gd, is_);
        e.loaded = true;
        connect_instances();
    }

    void connect_instances()
    {
        NamedGridMap named;
        for (const Entry &e : entries) {
            if (e.loaded)
                named[e.gd.uniqueName()] = e.grid;
        }
        for (const Entry &e : entries) {
            if (e.loaded && e.gd.isInstance() && named.count(e.gd.instanceParentName()))
                connectInstance(e.gd, named);
        }
    }
};

/* Human-readable name: "density", or "density@1" for the second of several. */
std::string display_name(const Reader &r, size_t index)
{
    const std::string &name = r.entries[index].gd.gridName();
    int before = 0, total = 0;
    for (size_t i = 0; i < r.entries.size(); ++i) {
        if (r.entries[i].gd.gridName() == name) {
            if (i < index)
                ++before;
            ++total;
        }
    }
    return total > 1 ? format("%s@%d", name.c_str(), before) : name;
}

std::string value_type(const Reader &r, size_t index)
{
    const Reader::Entry &e = r.entries[index];
    return e.grid ? e.grid->valueType() : e.gd.gridType();
}

std::string grid_list(const Reader &r)
{
    std::string out;
    /* The error line must stay readable (and fit vdbs_error) for files with many grids. */
    const size_t shown = std::min<size_t>(r.entries.size(), 16);
    for (size_t i = 0; i < shown; ++i) {
        if (i)
            out += ", ";
        out += sanitize(display_name(r, i), 60) + " (" + sanitize(value_type(r, i), 30) + ")";
    }
    if (shown < r.entries.size())
        out += format(" and %zu more", r.entries.size() - shown);
    return out;
}

/* Writes through Archive's protected stream API so that write errors on our own
 * std::ofstream are seen (io::File::write does not check them). */
class Writer : public openvdb::io::Archive
{
  public:
    void write_to(std::ostream &os, const openvdb::GridCPtrVec &grids,
                  const openvdb::MetaMap &meta) const
    {
        Archive::write(os, grids, /*seekable=*/true, meta);
    }
};

struct ActiveStats {
    float vmin = 0.0f, vmax = 0.0f;
    bool any = false;
    uint64_t nonfinite = 0, negative = 0;
    Coord first_nonfinite, first_negative;
    float nonfinite_value = 0.0f, negative_value = 0.0f;
};

ActiveStats active_stats(const FloatTree &tree)
{
    ActiveStats s;
    for (auto it = tree.cbeginValueOn(); it; ++it) {
        const float v = *it;
        const uint64_t n = it.isVoxelValue() ? 1 : it.getVoxelCount();
        if (!std::isfinite(v)) {
            if (s.nonfinite == 0) {
                s.first_nonfinite = it.getCoord();
                s.nonfinite_value = v;
            }
            s.nonfinite += n;
        } else if (v < 0.0f) {
            if (s.negative == 0) {
                s.first_negative = it.getCoord();
                s.negative_value = v;
            }
            s.negative += n;
        } else if (!s.any) {
            s.vmin = s.vmax = v;
            s.any = true;
        } else {
            s.vmin = std::min(s.vmin, v);
            s.vmax = std::max(s.vmax, v);
        }
    }
    return s;
}

/* Zero is the only value the samplers may see outside the active region. */
void zero_inactive(FloatTree &tree)
{
    for (auto it = tree.beginValueOff(); it; ++it)
        it.setValue(0.0f);
    tree.root().setBackground(0.0f, /*updateChildNodes=*/false);
}

} // namespace

struct vdbio_density {
    FloatGrid::Ptr grid;
    vdbio_density_info info;
};

namespace
{

void fill_info(vdbio_density &d, const std::string &name, const char *source_type,
               double original_background, const ActiveStats &stats)
{
    vdbio_density_info &info = d.info;
    memset(&info, 0, sizeof info);
    copy_string(info.name, sizeof info.name, name);
    copy_string(info.source_type, sizeof info.source_type, source_type);
    info.transform = transform_to_c(d.grid->transform());
    voxel_size_of(info.transform, info.voxel_size);
    const FloatTree &tree = d.grid->tree();
    info.active_voxels = tree.activeVoxelCount();
    info.active_tiles = tree.activeTileCount();
    bbox_to_c(d.grid->evalActiveVoxelBoundingBox(), info.active_voxels == 0, info.bbox_min,
              info.bbox_max);
    info.value_min = stats.vmin;
    info.value_max = stats.vmax;
    info.original_background = original_background;
}

void warn(vdbs_warn_fn fn, void *user, const std::string &message)
{
    if (fn)
        fn(user, message.c_str());
}

/* Picks the descriptor index for the read options; throws on every ambiguity. */
size_t select_grid(const Reader &r, const vdbio_read_options &o)
{
    const std::string &path = r.path;
    if (r.entries.empty())
        fail(VDBS_ERR_INPUT, format("%s: the file contains no grids", path.c_str()));
    if (o.grid_index < 0)
        fail(VDBS_ERR_INPUT, format("%s: grid index %d is negative", path.c_str(), o.grid_index));
    const std::string wanted = o.grid_name ? o.grid_name : "density";
    std::vector<size_t> named;
    for (size_t i = 0; i < r.entries.size(); ++i) {
        if (r.entries[i].gd.gridName() == wanted)
            named.push_back(i);
    }
    if (named.empty() && !o.grid_name) {
        std::vector<size_t> scalar;
        for (size_t i = 0; i < r.entries.size(); ++i) {
            const std::string t = value_type(r, i);
            if (t == "float" || t == "double")
                scalar.push_back(i);
        }
        if (scalar.size() == 1 && o.grid_index == 0)
            return scalar[0];
        fail(VDBS_ERR_INPUT,
             format("%s: no grid named \"density\" and %s; grids: %s", path.c_str(),
                    scalar.empty() ? "no float grid" : "several float grids (pick one with --grid)",
                    grid_list(r).c_str()));
    }
    if (named.empty())
        fail(VDBS_ERR_INPUT, format("%s: no grid named \"%s\"; grids: %s", path.c_str(),
                                    sanitize(wanted, 80).c_str(), grid_list(r).c_str()));
    if (static_cast<size_t>(o.grid_index) >= named.size())
        fail(VDBS_ERR_INPUT,
             format("%s: grid index %d out of range: %zu grid%s named \"%s\"", path.c_str(),
                    o.grid_index, named.size(), named.size() == 1 ? " is" : "s are",
                    sanitize(wanted, 80).c_str()));
    if (named.size() > 1 && o.grid_index == 0)
        warn(o.warn, o.warn_user,
             format("%s: %zu grids are named \"%s\"; using the first (--grid %s@1 picks another)",
                    path.c_str(), named.size(), sanitize(wanted, 80).c_str(),
                    sanitize(wanted, 80).c_str()));
    return named[static_cast<size_t>(o.grid_index)];
}

/* The grid as float (a double grid converted), with its metadata and transform. */
FloatGrid::Ptr float_grid(const GridBase::Ptr &base, const std::string &type)
{
    FloatGrid::Ptr grid;
    if (type == "double") {
        auto dgrid = openvdb::gridPtrCast<openvdb::DoubleGrid>(base);
        if (!dgrid)
            fail(VDBS_ERR_INTERNAL, "double grid cast failed");
        grid = FloatGrid::create(std::make_shared<FloatTree>(dgrid->tree()));
        grid->insertMeta(*dgrid);
        grid->setTransform(dgrid->transform().copy());
    } else {
        grid = openvdb::gridPtrCast<FloatGrid>(base);
        if (!grid)
            fail(VDBS_ERR_INTERNAL, "float grid cast failed");
    }
    return grid;
}

/* An affine fog volume: a level set only with from_levelset, which converts it. */
void require_fog_volume(FloatGrid &grid, const vdbio_read_options &o, const char *path,
                        const std::string &gname)
{
    if (!grid.transform().isLinear())
        fail(VDBS_ERR_INPUT,
             format("%s: grid \"%s\" has a non-linear (%s) transform; only affine transforms "
                    "are supported",
                    path, gname.c_str(), grid.transform().mapType().c_str()));
    const openvdb::GridClass cls = grid.getGridClass();
    if (cls == openvdb::GRID_LEVEL_SET && !o.from_levelset)
        fail(VDBS_ERR_INPUT,
             format("%s: grid \"%s\" is a level set (signed distance), not a density; pass "
                    "--from-levelset to convert it to a fog volume",
                    path, gname.c_str()));
    if (o.from_levelset) {
        if (cls == openvdb::GRID_FOG_VOLUME) {
            warn(o.warn, o.warn_user,
                 format("%s: grid \"%s\" is already a fog volume; --from-levelset ignored", path,
                        gname.c_str()));
        } else {
            openvdb::tools::sdfToFogVolume(grid);
        }
    }
}

/* Refuses NaN, Inf and negative active values, naming the first of each. cls is the grid's
 * class as read (before any conversion). */
void require_valid_values(const ActiveStats &s, const FloatGrid &grid, openvdb::GridClass cls,
                          const std::string &type, const vdbio_read_options &o, const char *path,
                          const std::string &gname)
{
    if (!s.nonfinite && !s.negative)
        return;
    std::string what;
    const openvdb::math::Transform &t = grid.transform();
    if (s.nonfinite)
        what += format("%llu NaN/Inf active value%s (first %g at index %s, world %s)%s",
                       static_cast<unsigned long long>(s.nonfinite), s.nonfinite == 1 ? "" : "s",
                       static_cast<double>(s.nonfinite_value), coord_str(s.first_nonfinite).c_str(),
                       world_str(t, s.first_nonfinite).c_str(),
                       type == "double" ? " after conversion to float" : "");
    if (s.nonfinite && s.negative)
        what += " and ";
    if (s.negative)
        what += format("%llu negative active value%s (first %g at index %s, world %s)",
                       static_cast<unsigned long long>(s.negative), s.negative == 1 ? "" : "s",
                       static_cast<double>(s.negative_value), coord_str(s.first_negative).c_str(),
                       world_str(t, s.first_negative).c_str());
    const bool hint = s.negative && cls != openvdb::GRID_FOG_VOLUME && !o.from_levelset;
    fail(VDBS_ERR_INPUT,
         format("%s: grid \"%s\" has %s%s", path, gname.c_str(), what.c_str(),
                hint ? "; if it is a signed distance field, pass --from-levelset" : ""));
}

void density_read(const char *path, const vdbio_read_options *options, vdbio_density **out)
{
    if (!path || !out)
        fail(VDBS_ERR_INTERNAL, "vdbio_density_read: NULL argument");
    vdbio_read_options o;
    memset(&o, 0, sizeof o);
    if (options)
        o = *options;

    Reader r;
    r.open(path, /*load_all=*/false);
    const size_t index = select_grid(r, o);
    const std::string label = display_name(r, index);
    const std::string gname = sanitize(label, 120);
    const std::string type = value_type(r, index);
    if (type != "float" && type != "double")
        fail(VDBS_ERR_INPUT,
             format("%s: grid \"%s\" holds %s values; a density must be a float or double grid",
                    path, gname.c_str(), sanitize(type, 40).c_str()));

    FloatGrid::Ptr grid = float_grid(r.load(index), type);
    const double original_background = static_cast<double>(grid->background());
    const openvdb::GridClass cls = grid->getGridClass();
    require_fog_volume(*grid, o, path, gname);

    if (grid->tree().activeVoxelCount() == 0)
        fail(VDBS_ERR_INPUT,
             format("%s: grid \"%s\" is empty (no active voxels)", path, gname.c_str()));

    const double background = static_cast<double>(grid->background());
    zero_inactive(grid->tree());
    if (background != 0.0)
        warn(o.warn, o.warn_user,
             format("%s: grid \"%s\" has background %g; background and inactive values reset "
                    "to 0",
                    path, gname.c_str(), background));

    const ActiveStats s = active_stats(grid->tree());
    require_valid_values(s, *grid, cls, type, o, path, gname);

    auto d = std::make_unique<vdbio_density>();
    d->grid = grid;
    d->grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    fill_info(*d, label, type.c_str(), original_background, s);
    *out = d.release();
}

void density_from_dense(const float *values, const int dims[3], const int origin[3],
                        const vdbio_transform *transform, const char *name, vdbio_density **out)
{
    if (!values || !dims || !out)
        fail(VDBS_ERR_INTERNAL, "vdbio_density_from_dense: NULL argument");
    for (int a = 0; a < 3; ++a) {
        if (dims[a] <= 0) /* the shape of the caller's own array: a caller's mistake */
            fail(VDBS_ERR_INTERNAL, format("dense grid dimensions %d x %d x %d are not positive",
                                           dims[0], dims[1], dims[2]));
    }
    const std::string gname = name ? name : "density";
    const Coord o = origin ? Coord(origin[0], origin[1], origin[2]) : Coord(0);
    FloatGrid::Ptr grid = FloatGrid::create(0.0f);
    grid->setTransform(transform_from_c(transform));
    grid->setName(gname);
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    auto acc = grid->getAccessor();
    const size_t nx = static_cast<size_t>(dims[0]), ny = static_cast<size_t>(dims[1]);
    uint64_t nonfinite = 0;
    Coord first_bad;
    for (int k = 0; k < dims[2]; ++k) {
        for (int j = 0; j < dims[1]; ++j) {
            const float *row = values + (static_cast<size_t>(k) * ny + j) * nx;
            for (int i = 0; i < dims[0]; ++i) {
                const float v = row[i];
                if (!std::isfinite(v)) {
                    if (nonfinite++ == 0)
                        first_bad = o + Coord(i, j, k);
                } else if (v > 0.0f) {
                    acc.setValueOn(o + Coord(i, j, k), v);
                }
            }
        }
    }
    if (nonfinite)
        fail(VDBS_ERR_INPUT,
             format("dense grid \"%s\" has %llu NaN/Inf values (first at index %s)",
                    sanitize(gname, 120).c_str(), static_cast<unsigned long long>(nonfinite),
                    coord_str(first_bad).c_str()));
    auto d = std::make_unique<vdbio_density>();
    d->grid = grid;
    fill_info(*d, gname, "float", 0.0, active_stats(grid->tree()));
    *out = d.release();
}

/* realpath() of a path whose last component may not exist yet. */
std::string resolve(const char *path)
{
    char buf[PATH_MAX];
    if (realpath(path, buf))
        return buf;
    return std::string();
}

bool same_file(const char *out, const char *in)
{
    struct stat so, si;
    if (!in || stat(in, &si) != 0)
        return false;
    if (stat(out, &so) == 0 && so.st_dev == si.st_dev && so.st_ino == si.st_ino)
        return true;
    const std::string a = resolve(out), b = resolve(in);
    return !a.empty() && a == b;
}

/* Refuses outputs that can never be written, before any work is done. */
void check_output(const char *path, const char *input_path)
{
    if (!path) /* a caller's mistake, like the NULL arguments elsewhere; "" is the user's */
        fail(VDBS_ERR_INTERNAL, "no output path");
    if (!path[0])
        fail(VDBS_ERR_INPUT, "no output path");
    if (same_file(path, input_path))
        fail(VDBS_ERR_INPUT,
             format("%s: refusing to overwrite the input file %s", path, input_path));
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        fail(VDBS_ERR_INPUT, format("%s: is a directory, not an output file", path));
    std::string dir(path);
    const size_t slash = dir.find_last_of('/');
    dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : dir.substr(0, slash));
    if (stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
        fail(VDBS_ERR_INPUT, format("%s: the folder %s does not exist", path, dir.c_str()));
    if (access(dir.c_str(), W_OK) != 0)
        fail(VDBS_ERR_INPUT, format("%s: the folder %s is not writable", path, dir.c_str()));
}

bool reserved_grid_meta(const std::string &key)
{
    static const char *const names[] = {"name",        "class",          "value_type",
                                        "vector_type", "is_local_space", "is_saved_as_half_float"};
    for (const char *n : names) {
        if (key == n)
            return true;
    }
    return key.compare(0, 5, "file_") == 0;
}

void check_write_request(const char *path, const vdbio_write_request *req)
{
    if (!path || !req || !req->density || !req->density->grid)
        fail(VDBS_ERR_INTERNAL, "vdbio_write: NULL argument");
    if (req->coord_count && !req->coords)
        fail(VDBS_ERR_INTERNAL, "vdbio_write: coordinates missing");
    if (req->vec3_grid_count < 0 || (req->vec3_grid_count && !req->vec3_grids) ||
        req->float_grid_count < 0 || (req->float_grid_count && !req->float_grids) ||
        req->file_meta_count < 0 || (req->file_meta_count && !req->file_meta))
        fail(VDBS_ERR_INTERNAL, "vdbio_write: bad grid or metadata list");
}

/* The density as written: the caller's tree, or with half floats a copy clamped to the half
 * range when any value lies beyond it (counted into clamped). */
FloatGrid::Ptr density_for_write(const vdbio_write_request *req, uint64_t &clamped)
{
    const FloatGrid &src = *req->density->grid;
    FloatGrid::Ptr density;
    if (req->half) {
        bool big = false;
        for (auto it = src.tree().cbeginValueAll(); it && !big; ++it)
            big = std::fabs(*it) > kHalfMax;
        if (big) {
            density = FloatGrid::create(std::make_shared<FloatTree>(src.tree()));
            for (auto it = density->tree().beginValueAll(); it; ++it) {
                const float v = *it;
                if (std::fabs(v) > kHalfMax) {
                    it.setValue(std::copysign(kHalfMax, v));
                    clamped += it.isVoxelValue() ? 1 : it.getVoxelCount();
                }
            }
        }
    }
    if (!density)
        density = FloatGrid::create(req->density->grid->treePtr());
    density->setTransform(src.transform().copy());
    density->setName("density");
    density->setGridClass(openvdb::GRID_FOG_VOLUME);
    density->setSaveFloatAsHalf(req->half != 0);
    return density;
}

/* The request's vec3 grid g over its output voxels, named uniquely among the grids so far
 * (`all`); with half floats clamped to the half range (counted into clamped). */
Vec3SGrid::Ptr vec3_for_write(const vdbio_write_request *req, int g,
                              const std::vector<GridBase::Ptr> &all, uint64_t &clamped)
{
    const vdbio_vec3_grid &vg = req->vec3_grids[g];
    if (!vg.name || !vg.name[0] || (!vg.values && req->coord_count))
        fail(VDBS_ERR_INTERNAL, format("vdbio_write: vec3 grid %d has no name or values", g));
    for (const GridBase::Ptr &other : all) {
        if (other->getName() == vg.name)
            fail(VDBS_ERR_INTERNAL, format("vdbio_write: two grids named \"%s\"", vg.name));
    }
    Vec3SGrid::Ptr grid = Vec3SGrid::create(openvdb::Vec3s(0.0f));
    grid->setName(vg.name);
    grid->setTransform(req->density->grid->transform().copy());
    grid->setGridClass(openvdb::GRID_UNKNOWN);
    grid->setVectorType(openvdb::VEC_INVARIANT);
    grid->setSaveFloatAsHalf(req->half != 0);
    auto acc = grid->getAccessor();
    for (size_t i = 0; i < req->coord_count; ++i) {
        const int32_t *c = req->coords + 3 * i;
        openvdb::Vec3s v(vg.values[3 * i], vg.values[3 * i + 1], vg.values[3 * i + 2]);
        if (req->half) {
            for (int a = 0; a < 3; ++a) {
                if (std::fabs(v[a]) > kHalfMax) {
                    v[a] = std::copysign(kHalfMax, v[a]);
                    ++clamped;
                }
            }
        }
        acc.setValueOn(Coord(c[0], c[1], c[2]), v);
    }
    return grid;
}

/* The request's float grid g, as vec3_for_write; a half grid's values are rounded to half
 * here (clamped beyond its range), so that saving it as half loses nothing more. */
FloatGrid::Ptr float_for_write(const vdbio_write_request *req, int g,
                               const std::vector<GridBase::Ptr> &all, uint64_t &clamped)
{
    const vdbio_float_grid &fg = req->float_grids[g];
    if (!fg.name || !fg.name[0] || (!fg.values && (fg.coords ? fg.coord_count : req->coord_count)))
        fail(VDBS_ERR_INTERNAL, format("vdbio_write: float grid %d has no name or values", g));
    for (const GridBase::Ptr &other : all) {
        if (other->getName() == fg.name)
            fail(VDBS_ERR_INTERNAL, format("vdbio_write: two grids named \"%s\"", fg.name));
    }
    const bool half = req->half || fg.half;
    const int32_t *coords = fg.coords ? fg.coords : req->coords;
    const size_t count = fg.coords ? fg.coord_count : req->coord_count;
    FloatGrid::Ptr grid = FloatGrid::create(0.0f);
    grid->setName(fg.name);
    grid->setTransform(fg.transform ? transform_from_c(fg.transform)
                                    : req->density->grid->transform().copy());
    grid->setGridClass(openvdb::GRID_UNKNOWN);
    grid->setSaveFloatAsHalf(half);
    auto acc = grid->getAccessor();
    for (size_t i = 0; i < count; ++i) {
        const int32_t *c = coords + 3 * i;
        float v = fg.values[i];
        if (half) {
            if (std::fabs(v) > kHalfMax) {
                v = std::copysign(kHalfMax, v);
                ++clamped;
            }
            v = static_cast<float>(openvdb::math::half(v));
        }
        acc.setValueOn(Coord(c[0], c[1], c[2]), v);
    }
    return grid;
}

/* The file's metadata (a "creator" unless given); every key that is not one of OpenVDB's
 * own per-grid keys goes on each grid too. */
openvdb::MetaMap file_metadata(const vdbio_write_request *req,
                               const std::vector<GridBase::Ptr> &all)
{
    openvdb::MetaMap file_meta;
    bool has_creator = false;
    for (int m = 0; m < req->file_meta_count; ++m) {
        const vdbio_meta &kv = req->file_meta[m];
        if (!kv.key || !kv.key[0] || !kv.value)
            fail(VDBS_ERR_INTERNAL, format("vdbio_write: metadata entry %d is incomplete", m));
        file_meta.insertMeta(kv.key, openvdb::StringMetadata(kv.value));
        has_creator = has_creator || strcmp(kv.key, "creator") == 0;
        if (!reserved_grid_meta(kv.key)) {
            for (const GridBase::Ptr &g : all)
                g->insertMeta(kv.key, openvdb::StringMetadata(kv.value));
        }
    }
    if (!has_creator)
        file_meta.insertMeta("creator", openvdb::StringMetadata("vdbscatter"));
    return file_meta;
}

/* A hidden temporary file beside the output, for the rename into place. */
std::string temporary_path(const char *path)
{
    const std::string out = path;
    const size_t slash = out.rfind('/');
    const std::string base = slash == std::string::npos ? out : out.substr(slash + 1);
    if (base.empty())
        fail(VDBS_ERR_INPUT, format("%s: output path names a directory", path));
    char *tmp = vdbs_temp_path(path);
    if (!tmp)
        throw std::bad_alloc();
    const std::string out_tmp = tmp;
    free(tmp);
    return out_tmp;
}

/* Writes body's bytes to tmp and syncs them: the data must be on disk before a rename makes
 * it visible. Failures throw; removing tmp is the caller's (with_temporaries). */
template <typename F> void write_synced(const char *path, const std::string &tmp, F &&body)
{
    vdbs_fault_point("before-write", nullptr);
    std::ofstream os(tmp, std::ios::out | std::ios::binary | std::ios::trunc);
    if (!os)
        fail(VDBS_ERR_IO, format("%s: cannot create %s: %s", path, tmp.c_str(), strerror(errno)));
    body(os);
    os.flush();
    os.close();
    if (os.fail())
        fail(VDBS_ERR_IO, format("%s: writing %s failed: %s", path, tmp.c_str(), strerror(errno)));
    vdbs_error err;
    if (vdbs_temp_sync(tmp.c_str(), path, &err) != VDBS_OK)
        fail(VDBS_ERR_IO, err.message);
}

void rename_into_place(const char *path, const std::string &tmp, const std::string &dest)
{
    vdbs_error err;
    if (vdbs_temp_rename(tmp.c_str(), dest.c_str(), path, &err) != VDBS_OK)
        fail(VDBS_ERR_IO, err.message);
}

/* Runs body; on any failure (a cancel included) every temporary file is removed, so the old
 * outputs stay, and a library's exception becomes an output error naming the library. */
template <typename F>
void with_temporaries(const char *path, const std::vector<std::string> &tmps, const char *library,
                      F &&body)
{
    auto remove_all = [&] {
        for (const std::string &t : tmps)
            unlink(t.c_str());
    };
    try {
        body();
    } catch (const Failure &) {
        remove_all();
        throw;
    } catch (const std::bad_alloc &) {
        remove_all();
        throw;
    } catch (const std::exception &e) {
        remove_all();
        fail(VDBS_ERR_IO,
             format("%s: writing failed (%s: %s)", path, library, sanitize(e.what()).c_str()));
    } catch (...) {
        remove_all();
        throw;
    }
}

/* Writes the grids to tmp, syncs it and renames it onto path; on any failure (a cancel
 * included) tmp is removed and the old file stays. */
void write_atomically(const char *path, const std::string &tmp, const openvdb::GridCPtrVec &grids,
                      const openvdb::MetaMap &file_meta, const vdbs_cancel *cancel)
{
    vdbs_temp_remove_stale(path);
    with_temporaries(path, {tmp}, "OpenVDB", [&] {
        write_synced(path, tmp, [&](std::ostream &os) { Writer().write_to(os, grids, file_meta); });
        /* The write itself cannot stop midway; a cancel that came during it ends here, before
         * the new file replaces the old one. */
        if (vdbs_cancelled(cancel))
            fail(VDBS_ERR_CANCELLED, VDBS_CANCELLED_MESSAGE);
        rename_into_place(path, tmp, path);
    });
}

bool has_suffix(const char *path, const char *suffix)
{
    const size_t n = strlen(path), e = strlen(suffix);
    if (n <= e || path[n - e - 1] == '/')
        return false;
    for (size_t i = 0; i < e; ++i) {
        if (tolower(static_cast<unsigned char>(path[n - e + i])) !=
            tolower(static_cast<unsigned char>(suffix[i])))
            return false;
    }
    return true;
}

/* The NanoVDB sidecar: the file metadata a shader needs, which NanoVDB cannot hold. */
std::string sidecar_path(const char *path)
{
    return std::string(path) + ".json";
}

/* A JSON string literal; bytes >= 0x80 pass through (the values are UTF-8). */
std::string json_string(const std::string &text)
{
    std::string out = "\"";
    for (unsigned char c : text) {
        switch (c) {
        case '"':
            out += "\\\"";
            break;
        case '\\':
            out += "\\\\";
            break;
        case '\n':
            out += "\\n";
            break;
        case '\t':
            out += "\\t";
            break;
        case '\r':
            out += "\\r";
            break;
        default:
            if (c < 0x20)
                out += format("\\u%04x", c);
            else
                out += static_cast<char>(c);
        }
    }
    return out + "\"";
}

/* The .vdb's file metadata as one JSON object, key for key (every value is a string). */
std::string metadata_json(const openvdb::MetaMap &meta)
{
    std::string out = "{";
    bool first = true;
    for (auto it = meta.beginMeta(); it != meta.endMeta(); ++it) {
        out += first ? "\n  " : ",\n  ";
        first = false;
        out += json_string(it->first) + ": " + json_string(it->second->str());
    }
    return out + "\n}\n";
}

float half_rounded(float v)
{
    return static_cast<float>(openvdb::math::half(v));
}

/* A grid saved as half floats in a .vdb reads back rounded; NanoVDB stores float, so it gets
 * the rounded values themselves (a copy: the density's tree may be the caller's). */
FloatGrid::Ptr as_read_back(const FloatGrid &grid)
{
    FloatGrid::Ptr copy = grid.deepCopy();
    if (grid.saveFloatAsHalf()) {
        for (auto it = copy->tree().beginValueAll(); it; ++it)
            it.setValue(half_rounded(*it));
    }
    return copy;
}

Vec3SGrid::Ptr as_read_back(const Vec3SGrid &grid)
{
    Vec3SGrid::Ptr copy = grid.deepCopy();
    if (grid.saveFloatAsHalf()) {
        for (auto it = copy->tree().beginValueAll(); it; ++it) {
            const openvdb::Vec3s v = *it;
            it.setValue(openvdb::Vec3s(half_rounded(v[0]), half_rounded(v[1]), half_rounded(v[2])));
        }
    }
    return copy;
}

using NanoHandle = nanovdb::GridHandle<nanovdb::HostBuffer>;

/* Each grid as NanoVDB makes it from OpenVDB (name, class and the affine map carried over):
 * float stays float, vec3s becomes Vec3f. */
std::vector<NanoHandle> nanovdb_grids(const std::vector<GridBase::Ptr> &all)
{
    std::vector<NanoHandle> handles;
    for (const GridBase::Ptr &g : all) {
        if (auto f = openvdb::GridBase::grid<FloatGrid>(g)) {
            FloatGrid::Ptr h = f->saveFloatAsHalf() ? as_read_back(*f) : f;
            handles.push_back(nanovdb::openToNanoVDB(*h));
        } else if (auto v = openvdb::GridBase::grid<Vec3SGrid>(g)) {
            Vec3SGrid::Ptr h = v->saveFloatAsHalf() ? as_read_back(*v) : v;
            handles.push_back(nanovdb::openToNanoVDB(*h));
        } else {
            fail(VDBS_ERR_INTERNAL,
                 format("vdbio_write: grid \"%s\" has no NanoVDB type", g->getName().c_str()));
        }
    }
    return handles;
}

/* An exclusive flock on the output's folder while held: two processes writing the same
 * .nvdb at once would otherwise interleave their two renames and leave one's grids with the
 * other's sidecar. Advisory (vdbscatter processes only), released by the kernel when the
 * process dies; best effort: a folder that cannot be locked is written unlocked. */
class FolderLock
{
  public:
    explicit FolderLock(const char *path)
    {
        std::string dir(path);
        const size_t slash = dir.find_last_of('/');
        dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : dir.substr(0, slash));
        fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        while (fd_ >= 0 && flock(fd_, LOCK_EX) != 0 && errno == EINTR) {
        }
    }
    ~FolderLock()
    {
        if (fd_ >= 0)
            close(fd_); /* releases the lock */
    }
    FolderLock(const FolderLock &) = delete;
    FolderLock &operator=(const FolderLock &) = delete;

  private:
    int fd_ = -1;
};

/* The .nvdb and its sidecar, each through its own temporary file: both are written and
 * synced before either is renamed, the sidecar first, so that a new .nvdb never appears
 * without its metadata; a cancel or failure before the renames leaves both old files. */
void nvdb_write_atomically(const char *path, const std::vector<NanoHandle> &handles,
                           const std::string &json, const vdbs_cancel *cancel)
{
    const std::string side = sidecar_path(path);
    const std::string tmp = temporary_path(path), side_tmp = temporary_path(side.c_str());
    vdbs_temp_remove_stale(path);
    vdbs_temp_remove_stale(side.c_str());
    with_temporaries(path, {tmp, side_tmp}, "NanoVDB", [&] {
        write_synced(path, side_tmp, [&](std::ostream &os) { os << json; });
        write_synced(path, tmp, [&](std::ostream &os) {
            nanovdb::io::writeGrids<nanovdb::HostBuffer, std::vector>(os, handles,
                                                                      nanovdb::io::Codec::NONE);
        });
        if (vdbs_cancelled(cancel))
            fail(VDBS_ERR_CANCELLED, VDBS_CANCELLED_MESSAGE);
        const FolderLock lock(path);
        rename_into_place(path, side_tmp, side);
        try {
            rename_into_place(path, tmp, path);
        } catch (...) {
            unlink(side.c_str()); /* no sidecar without its grids */
            throw;
        }
    });
}

void vdb_write(const char *path, const char *input_path, const vdbio_write_request *req)
{
    check_write_request(path, req);
    check_output(path, input_path);
    const bool nano = has_suffix(path, ".nvdb");
    if (!nano && !has_suffix(path, ".vdb"))
        fail(VDBS_ERR_INPUT, format("%s: expected a name ending in .vdb or .nvdb", path));
    if (nano && same_file(sidecar_path(path).c_str(), input_path))
        fail(VDBS_ERR_INPUT,
             format("%s: refusing to overwrite the input file %s with the metadata sidecar", path,
                    input_path));
    uint64_t clamped = 0;
    std::vector<GridBase::Ptr> all{density_for_write(req, clamped)};
    for (int g = 0; g < req->vec3_grid_count; ++g)
        all.push_back(vec3_for_write(req, g, all, clamped));
    for (int g = 0; g < req->float_grid_count; ++g)
        all.push_back(float_for_write(req, g, all, clamped));
    const openvdb::MetaMap file_meta = file_metadata(req, all);
    if (nano) {
        const std::vector<NanoHandle> handles = nanovdb_grids(all);
        const std::string json = metadata_json(file_meta);
        if (vdbs_cancelled(req->cancel))
            fail(VDBS_ERR_CANCELLED, VDBS_CANCELLED_MESSAGE);
        nvdb_write_atomically(path, handles, json, req->cancel);
    } else {
        openvdb::GridCPtrVec grids;
        for (const GridBase::Ptr &g : all)
            grids.push_back(g);
        const std::string tmp = temporary_path(path);
        if (vdbs_cancelled(req->cancel))
            fail(VDBS_ERR_CANCELLED, VDBS_CANCELLED_MESSAGE);
        write_atomically(path, tmp, grids, file_meta, req->cancel);
    }
    if (clamped)
        warn(req->warn, req->warn_user,
             format("%s: %llu value%s beyond the half-float range clamped to +-65504", path,
                    static_cast<unsigned long long>(clamped), clamped == 1 ? "" : "s"));
}

template <typename GridT> void scalar_range(const GridT &grid, double &lo, double &hi)
{
    bool any = false;
    for (auto it = grid.tree().cbeginValueOn(); it; ++it) {
        const double v = static_cast<double>(*it);
        if (std::isnan(v))
            continue;
        lo = any ? std::min(lo, v) : v;
        hi = any ? std::max(hi, v) : v;
        any = true;
    }
}

void summarize(const Reader &r, size_t index, vdbio_grid_summary &s)
{
    const GridBase &g = *r.entries[index].grid;
    memset(&s, 0, sizeof s);
    copy_string(s.name, sizeof s.name, r.entries[index].gd.gridName());
    copy_string(s.value_type, sizeof s.value_type, g.valueType());
    copy_string(s.grid_class, sizeof s.grid_class, GridBase::gridClassToString(g.getGridClass()));
    s.is_affine = g.transform().isLinear() ? 1 : 0;
    s.transform = transform_to_c(g.transform());
    voxel_size_of(s.transform, s.voxel_size);
    s.active_voxels = g.activeVoxelCount();
    s.active_tiles = g.baseTree().activeTileCount();
    bbox_to_c(g.evalActiveVoxelBoundingBox(), s.active_voxels == 0, s.bbox_min, s.bbox_max);
    if (const auto *f = dynamic_cast<const FloatGrid *>(&g)) {
        s.background = f->background();
        scalar_range(*f, s.value_min, s.value_max);
    } else if (const auto *d = dynamic_cast<const openvdb::DoubleGrid *>(&g)) {
        s.background = d->background();
        scalar_range(*d, s.value_min, s.value_max);
    } else if (const auto *i32 = dynamic_cast<const openvdb::Int32Grid *>(&g)) {
        s.background = i32->background();
    } else if (const auto *i64 = dynamic_cast<const openvdb::Int64Grid *>(&g)) {
        s.background = static_cast<double>(i64->background());
    } else if (const auto *b = dynamic_cast<const openvdb::BoolGrid *>(&g)) {
        s.background = b->background() ? 1.0 : 0.0;
    }
}

/* Per-thread accessor cache for vdbio_lit lookups: a vdbio_lit may be shared by
 * many threads, so it cannot own mutable accessors. */
template <typename TreeT> struct LitCache {
    uint64_t serial = 0;
    const void *grid = nullptr;
    std::unique_ptr<openvdb::tree::ValueAccessor<const TreeT, false>> acc;
};

std::atomic<uint64_t> lit_serial{1};

} // namespace

struct vdbio_lit {
    std::string path;
    std::vector<GridBase::Ptr> grids;
    std::map<std::string, std::string> meta;
    uint64_t serial;
};

namespace
{

const GridBase *lit_find(const vdbio_lit *lit, const char *name)
{
    if (!lit || !name)
        return nullptr;
    for (const GridBase::Ptr &g : lit->grids) {
        if (g->getName() == name)
            return g.get();
    }
    return nullptr;
}

template <typename GridT>
const GridT &lit_typed(const vdbio_lit *lit, const char *name, const char *want)
{
    if (!lit || !name)
        fail(VDBS_ERR_INTERNAL, "vdbio_lit: NULL argument");
    const GridBase *g = lit_find(lit, name);
    if (!g)
        fail(VDBS_ERR_INPUT, format("%s: no grid named \"%s\"", lit->path.c_str(), name));
    const GridT *t = dynamic_cast<const GridT *>(g);
    if (!t)
        fail(VDBS_ERR_INPUT, format("%s: grid \"%s\" holds %s values, not %s", lit->path.c_str(),
                                    name, g->valueType().c_str(), want));
    return *t;
}

template <typename GridT>
typename GridT::ValueType lit_lookup(const vdbio_lit *lit, const GridT &grid, const int ijk[3])
{
    thread_local LitCache<typename GridT::TreeType> cache;
    if (cache.serial != lit->serial || cache.grid != &grid || !cache.acc) {
        cache.acc.reset(
            new openvdb::tree::ValueAccessor<const typename GridT::TreeType, false>(grid.tree()));
        cache.serial = lit->serial;
        cache.grid = &grid;
    }
    const Coord c(ijk[0], ijk[1], ijk[2]);
    return cache.acc->isValueOn(c) ? cache.acc->getValue(c) : typename GridT::ValueType(0);
}

/* A NanoVDB grid as the C side and the GPU take it: 32-byte aligned malloc'd memory whose
 * size is a multiple of 32 bytes (zero padded). */
template <typename Handle> void copy_nanovdb(const Handle &handle, void **buffer, size_t *size)
{
    const size_t n = handle.size();
    const size_t padded = (n + 31) / 32 * 32;
    void *mem = aligned_alloc(32, padded ? padded : 32);
    if (!mem)
        throw std::bad_alloc();
    memcpy(mem, handle.data(), n);
    memset(static_cast<char *>(mem) + n, 0, padded - n);
    *buffer = mem;
    *size = padded;
}

} // namespace

namespace
{

/* The child's result travels through a memory file (contain.h): status, message,
 * warnings, then the payload. Grids go as an uncompressed OpenVDB stream that OpenVDB
 * wrote itself from a tree it had read, so the parent's read of it is trusted and costs
 * about a memory copy instead of a second decompression of the file. */
class FdOutBuf : public std::streambuf
{
  public:
    explicit FdOutBuf(int fd) : fd_(fd)
    {
        setp(buf_, buf_ + sizeof buf_);
    }
    bool ok() const
    {
        return ok_;
    }
    int sync() override
    {
        if (pptr() > pbase() &&
            vdbs_contain_write(fd_, pbase(), static_cast<size_t>(pptr() - pbase())) != 0)
            ok_ = false;
        setp(buf_, buf_ + sizeof buf_);
        return ok_ ? 0 : -1;
    }
    int_type overflow(int_type c) override
    {
        if (sync() != 0)
            return traits_type::eof();
        if (c != traits_type::eof()) {
            *pptr() = static_cast<char>(c);
            pbump(1);
        }
        return traits_type::not_eof(c);
    }

  private:
    int fd_;
    bool ok_ = true;
    char buf_[1 << 16];
};

class MemInBuf : public std::streambuf
{
  public:
    MemInBuf(const char *data, size_t size)
    {
        char *p = const_cast<char *>(data);
        setg(p, p, p + size);
    }
};

/* The message and warnings of the child's run. */
struct ChildLog {
    std::vector<std::string> warnings;
    static void collect(void *user, const char *message)
    {
        static_cast<ChildLog *>(user)->warnings.push_back(message ? message : "");
    }
};

void put_u64(std::ostream &os, uint64_t v)
{
    os.write(reinterpret_cast<const char *>(&v), sizeof v);
}
void put_str(std::ostream &os, const std::string &s)
{
    put_u64(os, s.size());
    os.write(s.data(), static_cast<std::streamsize>(s.size()));
}

/* Reads what the child wrote; the child is our own code, so a short result is a bug. */
class ChildResult
{
  public:
    explicit ChildResult(vdbs_contained result) : result_(result)
    {
    }
    ~ChildResult()
    {
        vdbs_contain_free(&result_);
    }
    uint64_t u64()
    {
        uint64_t v;
        take(&v, sizeof v);
        return v;
    }
    std::string str()
    {
        const uint64_t n = u64();
        if (n > result_.size - at_)
            fail(VDBS_ERR_INTERNAL, "OpenVDB reader: short result");
        std::string s(result_.data + at_, n);
        at_ += n;
        return s;
    }
    void take(void *dst, size_t n)
    {
        if (!result_.data || n > result_.size - at_)
            fail(VDBS_ERR_INTERNAL, "OpenVDB reader: short result");
        memcpy(dst, result_.data + at_, n);
        at_ += n;
    }
    /* The rest as an OpenVDB stream. */
    openvdb::io::Stream stream()
    {
        MemInBuf buf(result_.data + at_, result_.size - at_);
        std::istream is(&buf);
        return openvdb::io::Stream(is, /*delayLoad=*/false);
    }
    /* Status, message and warnings: replays the warnings, throws the child's failure. */
    void replay(vdbs_warn_fn warn_fn, void *warn_user)
    {
        const vdbs_status st = static_cast<vdbs_status>(u64());
        const std::string message = str();
        const uint64_t n = u64();
        for (uint64_t i = 0; i < n; ++i)
            warn(warn_fn, warn_user, str());
        if (st != VDBS_OK)
            fail(st, message);
    }

  private:
    vdbs_contained result_;
    size_t at_ = 0;
};

/* Runs body(os, log) in a contained child: body writes the payload after the header the
 * child writes from the status body returns. */
template <typename F> void contained(const char *path, F &&body, ChildResult *&result)
{
    struct Ctx {
        F *body;
    } ctx{&body};
    auto child = [](int fd, void *user) -> int {
        F &b = *static_cast<Ctx *>(user)->body;
        FdOutBuf buf(fd);
        std::ostream os(&buf);
        ChildLog log;
        vdbs_error e;
        e.message[0] = '\0';
        /* body reads and checks; what it returns writes the payload after the header. */
        std::function<void(std::ostream &)> payload;
        const vdbs_status st = guarded(&e, [&] { payload = b(log); });
        put_u64(os, static_cast<uint64_t>(st));
        put_str(os, st == VDBS_OK ? std::string() : std::string(e.message));
        put_u64(os, log.warnings.size());
        for (const std::string &w : log.warnings)
            put_str(os, w);
        if (st == VDBS_OK && payload) {
            try {
                payload(os);
            } catch (...) {
                return 3;
            }
        }
        os.flush();
        return buf.ok() && os ? 0 : 3;
    };
    vdbs_contained contained;
    vdbs_error e;
    const vdbs_status st =
        contain_run_without_tbb_workers(path, "OpenVDB", child, &ctx, &contained, &e);
    if (st != VDBS_OK)
        fail(st, e.message);
    result = new ChildResult(contained);
}

void write_stream(std::ostream &os, const openvdb::GridCPtrVec &grids, const openvdb::MetaMap &meta)
{
    openvdb::io::Stream out(os);
    out.setCompression(openvdb::io::COMPRESS_NONE);
    out.write(grids, meta);
}

void density_read_contained(const char *path, const vdbio_read_options *options,
                            vdbio_density **out)
{
    if (!path || !out)
        fail(VDBS_ERR_INTERNAL, "vdbio_density_read: NULL argument");
    ChildResult *raw = nullptr;
    contained(
        path,
        [&](ChildLog &log) -> std::function<void(std::ostream &)> {
            vdbio_read_options o;
            memset(&o, 0, sizeof o);
            if (options)
                o = *options;
            o.warn = ChildLog::collect;
            o.warn_user = &log;
            vdbio_density *d = nullptr;
            density_read(path, &o, &d);
            return [d](std::ostream &os) {
                os.write(reinterpret_cast<const char *>(&d->info), sizeof d->info);
                write_stream(os, openvdb::GridCPtrVec{d->grid}, openvdb::MetaMap());
            };
        },
        raw);
    std::unique_ptr<ChildResult> result(raw);
    result->replay(options ? options->warn : nullptr, options ? options->warn_user : nullptr);
    auto d = std::make_unique<vdbio_density>();
    result->take(&d->info, sizeof d->info);
    openvdb::GridPtrVecPtr grids = result->stream().getGrids();
    if (!grids || grids->size() != 1 || !(d->grid = openvdb::gridPtrCast<FloatGrid>((*grids)[0])))
        fail(VDBS_ERR_INTERNAL, "OpenVDB reader: no density grid in its result");
    *out = d.release();
}

} // namespace

extern "C" {

vdbs_status vdbio_list_grids(const char *path, vdbio_grid_summary **grids, int *count,
                             vdbs_error *err)
{
    if (grids)
        *grids = nullptr;
    if (count)
        *count = 0;
    return guarded(err, [&] {
        if (!path || !grids || !count)
            fail(VDBS_ERR_INTERNAL, "vdbio_list_grids: NULL argument");
        ChildResult *raw = nullptr;
        contained(
            path,
            [&](ChildLog &) -> std::function<void(std::ostream &)> {
                Reader r;
                r.open(path, /*load_all=*/true);
                auto list = std::make_shared<std::vector<vdbio_grid_summary>>(r.entries.size());
                for (size_t i = 0; i < list->size(); ++i)
                    summarize(r, i, (*list)[i]);
                return [list](std::ostream &os) {
                    put_u64(os, list->size());
                    os.write(
                        reinterpret_cast<const char *>(list->data()),
                        static_cast<std::streamsize>(list->size() * sizeof(vdbio_grid_summary)));
                };
            },
            raw);
        std::unique_ptr<ChildResult> result(raw);
        result->replay(nullptr, nullptr);
        const uint64_t n = result->u64();
        if (n > INT_MAX)
            fail(VDBS_ERR_INTERNAL, "OpenVDB reader: bad grid count");
        auto *list =
            static_cast<vdbio_grid_summary *>(calloc(n ? n : 1, sizeof(vdbio_grid_summary)));
        if (!list)
            throw std::bad_alloc();
        try {
            result->take(list, n * sizeof(vdbio_grid_summary));
        } catch (...) {
            free(list);
            throw;
        }
        *grids = list;
        *count = static_cast<int>(n);
    });
}

vdbs_status vdbio_file_meta(const char *path, const char *key, char **value, vdbs_error *err)
{
    if (value)
        *value = nullptr;
    return guarded(err, [&] {
        if (!path || !key || !value)
            fail(VDBS_ERR_INTERNAL, "vdbio_file_meta: NULL argument");
        ChildResult *raw = nullptr;
        contained(
            path,
            [&](ChildLog &) -> std::function<void(std::ostream &)> {
                Reader r;
                r.open(path, /*load_all=*/false); /* the header: no grid is read */
                auto meta = r.file_meta.getMetadata<openvdb::StringMetadata>(key);
                const bool found = static_cast<bool>(meta);
                const std::string text = found ? meta->value() : std::string();
                return [found, text](std::ostream &os) {
                    put_u64(os, found ? 1 : 0);
                    put_str(os, text);
                };
            },
            raw);
        std::unique_ptr<ChildResult> result(raw);
        result->replay(nullptr, nullptr);
        const uint64_t found = result->u64();
        const std::string text = result->str();
        if (!found)
            return;
        *value = static_cast<char *>(malloc(text.size() + 1));
        if (!*value)
            throw std::bad_alloc();
        memcpy(*value, text.c_str(), text.size() + 1);
    });
}

/* --threads: the most worker threads TBB's pool may use, process-wide (0: no limit). */
void vdbio_thread_limit(int threads)
{
    static std::mutex lock;
    static std::unique_ptr<tbb::global_control> limit;
    std::lock_guard<std::mutex> hold(lock);
    try {
        limit.reset();
        if (threads > 0)
            limit = std::make_unique<tbb::global_control>(
                tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
    } catch (...) {
        /* out of memory: no limit */
    }
}

vdbs_status vdbio_density_read(const char *path, const vdbio_read_options *options,
                               vdbio_density **out, vdbs_error *err)
{
    if (out)
        *out = nullptr;
    return guarded(err, [&] { density_read_contained(path, options, out); });
}

vdbs_status vdbio_density_from_dense(const float *values, const int dims[3], const int origin[3],
                                     const vdbio_transform *transform, const char *name,
                                     vdbio_density **out, vdbs_error *err)
{
    if (out)
        *out = nullptr;
    return guarded(err, [&] { density_from_dense(values, dims, origin, transform, name, out); });
}

void vdbio_density_free(vdbio_density *density)
{
    delete density;
}

const vdbio_density_info *vdbio_density_get_info(const vdbio_density *density)
{
    return density ? &density->info : nullptr;
}

float vdbio_density_value(const vdbio_density *density, const int ijk[3])
{
    if (!density || !ijk)
        return 0.0f;
    return density->grid->tree().getValue(Coord(ijk[0], ijk[1], ijk[2]));
}

vdbs_status vdbio_density_to_nanovdb(const vdbio_density *density, void **buffer, size_t *size,
                                     vdbs_error *err)
{
    if (buffer)
        *buffer = nullptr;
    if (size)
        *size = 0;
    return guarded(err, [&] {
        if (!density || !buffer || !size)
            fail(VDBS_ERR_INTERNAL, "vdbio_density_to_nanovdb: NULL argument");
        copy_nanovdb(nanovdb::openToNanoVDB(*density->grid), buffer, size);
    });
}

vdbs_status vdbio_density_output_coords(const vdbio_density *density, int dilation,
                                        int32_t **coords, size_t *count, vdbs_error *err)
{
    if (coords)
        *coords = nullptr;
    if (count)
        *count = 0;
    return guarded(err, [&] {
        if (!density || !coords || !count)
            fail(VDBS_ERR_INTERNAL, "vdbio_density_output_coords: NULL argument");
        if (dilation < 0)
            fail(VDBS_ERR_INTERNAL,
                 format("vdbio_density_output_coords: dilation %d < 0", dilation));
        openvdb::MaskTree mask(density->grid->tree(), false, openvdb::TopologyCopy());
        mask.voxelizeActiveTiles();
        if (dilation > 0)
            openvdb::tools::dilateActiveValues(mask, dilation, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                               openvdb::tools::EXPAND_TILES);
        mask.voxelizeActiveTiles();
        const size_t n = static_cast<size_t>(mask.activeVoxelCount());
        if (n == 0)
            return;
        auto *list = static_cast<int32_t *>(malloc(n * 3 * sizeof(int32_t)));
        if (!list)
            throw std::bad_alloc();
        size_t i = 0;
        for (auto leaf = mask.cbeginLeaf(); leaf; ++leaf) {
            for (auto v = leaf->cbeginValueOn(); v; ++v) {
                const Coord c = v.getCoord();
                if (i < n) {
                    list[3 * i] = c.x();
                    list[3 * i + 1] = c.y();
                    list[3 * i + 2] = c.z();
                }
                ++i;
            }
        }
        if (i != n) {
            free(list);
            fail(VDBS_ERR_INTERNAL, "output coordinates: voxel count mismatch");
        }
        *coords = list;
        *count = n;
    });
}

vdbs_status vdbio_check_output(const char *path, const char *input_path, vdbs_error *err)
{
    return guarded(err, [&] { check_output(path, input_path); });
}

int64_t vdbio_write_bytes(const int64_t nodes[3], int vec3_grids, int float_grids,
                          int64_t float_samples)
{
    // A node's size holds its child table (InternalNode) or its masks (a leaf, whose values
    // are allocated beside it).
    using Vec3Tree = openvdb::Vec3SGrid::TreeType;
    using Vec3Leaf = Vec3Tree::LeafNodeType;
    using Vec3Inner = Vec3Tree::RootNodeType::ChildNodeType::ChildNodeType;
    using Vec3Top = Vec3Tree::RootNodeType::ChildNodeType;
    using FloatTree = FloatGrid::TreeType;
    using FloatInner = FloatTree::RootNodeType::ChildNodeType::ChildNodeType;
    using FloatTop = FloatTree::RootNodeType::ChildNodeType;
    const int64_t vec3 = nodes[0] * (int64_t)(sizeof(Vec3Leaf) + 512 * sizeof(openvdb::Vec3s)) +
                         nodes[1] * (int64_t)sizeof(Vec3Inner) +
                         nodes[2] * (int64_t)sizeof(Vec3Top);
    const int64_t leaves = (2 * float_samples + 511) / 512;
    const int64_t inner = float_grids + float_samples / (1 << 20);
    const int64_t floats =
        leaves * (int64_t)(sizeof(FloatTree::LeafNodeType) + 512 * sizeof(float)) +
        inner * (int64_t)sizeof(FloatInner) + float_grids * (int64_t)sizeof(FloatTop);
    return vec3_grids * vec3 + floats;
}

vdbs_status vdbio_write(const char *path, const char *input_path,
                        const vdbio_write_request *request, vdbs_error *err)
{
    return guarded(err, [&] { vdb_write(path, input_path, request); });
}

/* The lit VDB at path with every grid, or those whose names start with `prefix`. */
static vdbs_status lit_open(const char *path, const char *prefix, vdbio_lit **out, vdbs_error *err)
{
    if (out)
        *out = nullptr;
    return guarded(err, [&] {
        if (!path || !out)
            fail(VDBS_ERR_INTERNAL, "vdbio_lit_open: NULL argument");
        ChildResult *raw = nullptr;
        contained(
            path,
            [&](ChildLog &) -> std::function<void(std::ostream &)> {
                auto r = std::make_shared<Reader>();
                r->open(path, /*load_all=*/!prefix);
                const std::string start = prefix ? prefix : "";
                for (size_t i = 0; prefix && i < r->entries.size(); ++i)
                    if (r->entries[i].gd.gridName().compare(0, start.size(), start) == 0)
                        r->load(i);
                return [r](std::ostream &os) {
                    openvdb::GridCPtrVec grids;
                    for (const Reader::Entry &e : r->entries) {
                        if (!e.loaded)
                            continue;
                        e.grid->setName(e.gd.gridName());
                        grids.push_back(e.grid);
                    }
                    write_stream(os, grids, r->file_meta);
                };
            },
            raw);
        std::unique_ptr<ChildResult> result(raw);
        result->replay(nullptr, nullptr);
        openvdb::io::Stream stream = result->stream();
        openvdb::GridPtrVecPtr grids = stream.getGrids();
        openvdb::MetaMap::Ptr file_meta = stream.getMetadata();
        if (!grids || !file_meta)
            fail(VDBS_ERR_INTERNAL, "OpenVDB reader: no grids in its result");
        auto lit = std::make_unique<vdbio_lit>();
        lit->path = path;
        lit->serial = lit_serial.fetch_add(1);
        for (const GridBase::Ptr &g : *grids)
            lit->grids.push_back(g);
        for (auto it = file_meta->beginMeta(); it != file_meta->endMeta(); ++it) {
            if (it->second && it->second->typeName() == openvdb::StringMetadata::staticTypeName())
                lit->meta[it->first] =
                    static_cast<const openvdb::StringMetadata &>(*it->second).value();
        }
        *out = lit.release();
    });
}

vdbs_status vdbio_lit_open(const char *path, vdbio_lit **out, vdbs_error *err)
{
    return lit_open(path, nullptr, out, err);
}

vdbs_status vdbio_lit_open_prefix(const char *path, const char *prefix, vdbio_lit **out,
                                  vdbs_error *err)
{
    return lit_open(path, prefix ? prefix : "", out, err);
}

int vdbio_lit_has_grid(const vdbio_lit *lit, const char *name)
{
    return lit_find(lit, name) != nullptr;
}

vdbs_status vdbio_lit_vec3(const vdbio_lit *lit, const char *grid, const int ijk[3], float out[3],
                           vdbs_error *err)
{
    return guarded(err, [&] {
        if (!ijk || !out)
            fail(VDBS_ERR_INTERNAL, "vdbio_lit_vec3: NULL argument");
        const Vec3SGrid &g = lit_typed<Vec3SGrid>(lit, grid, "vec3s");
        const openvdb::Vec3s v = lit_lookup(lit, g, ijk);
        out[0] = v.x();
        out[1] = v.y();
        out[2] = v.z();
    });
}

vdbs_status vdbio_lit_vec3_many(const vdbio_lit *lit, const char *grid, const int *ijk,
                                size_t count, float *out, vdbs_error *err)
{
    return guarded(err, [&] {
        if ((!ijk || !out) && count)
            fail(VDBS_ERR_INTERNAL, "vdbio_lit_vec3_many: NULL argument");
        const Vec3SGrid &g = lit_typed<Vec3SGrid>(lit, grid, "vec3s");
        openvdb::tree::ValueAccessor<const Vec3STree, false> acc(g.tree());
        for (size_t n = 0; n < count; ++n) {
            const Coord c(ijk[3 * n], ijk[3 * n + 1], ijk[3 * n + 2]);
            const openvdb::Vec3s v = acc.isValueOn(c) ? acc.getValue(c) : openvdb::Vec3s(0.0f);
            out[3 * n] = v.x();
            out[3 * n + 1] = v.y();
            out[3 * n + 2] = v.z();
        }
    });
}

vdbs_status vdbio_lit_float(const vdbio_lit *lit, const char *grid, const int ijk[3], float *out,
                            vdbs_error *err)
{
    return guarded(err, [&] {
        if (!ijk || !out)
            fail(VDBS_ERR_INTERNAL, "vdbio_lit_float: NULL argument");
        const FloatGrid &g = lit_typed<FloatGrid>(lit, grid, "float");
        *out = lit_lookup(lit, g, ijk);
    });
}

vdbs_status vdbio_lit_dense(const vdbio_lit *lit, const char *grid, const int origin[3],
                            const int size[3], float *values, vdbs_error *err)
{
    return guarded(err, [&] {
        if (!lit || !grid || !origin || !size || !values)
            fail(VDBS_ERR_INTERNAL, "vdbio_lit_dense: NULL argument");
        const GridBase *g = lit_find(lit, grid);
        if (!g)
            fail(VDBS_ERR_INPUT, format("%s: no grid named \"%s\"", lit->path.c_str(), grid));
        const Coord lo(origin[0], origin[1], origin[2]);
        const openvdb::CoordBBox box(lo, lo + Coord(size[0] - 1, size[1] - 1, size[2] - 1));
        using openvdb::tools::LayoutXYZ;
        if (const auto *f = dynamic_cast<const FloatGrid *>(g)) {
            openvdb::tools::Dense<float, LayoutXYZ> dense(box, values);
            openvdb::tools::copyToDense(*f, dense);
        } else if (const auto *v = dynamic_cast<const openvdb::Vec3SGrid *>(g)) {
            static_assert(sizeof(openvdb::Vec3s) == 3 * sizeof(float), "Vec3s is 3 floats");
            openvdb::tools::Dense<openvdb::Vec3s, LayoutXYZ> dense(
                box, reinterpret_cast<openvdb::Vec3s *>(values));
            openvdb::tools::copyToDense(*v, dense);
        } else {
            fail(VDBS_ERR_INPUT, format("%s: grid \"%s\" holds %s values, not float or vec3s",
                                        lit->path.c_str(), grid, g->valueType().c_str()));
        }
    });
}

vdbs_status vdbio_lit_vec3_nanovdb(const vdbio_lit *lit, const char *grid, void **buffer,
                                   size_t *size, vdbs_error *err)
{
    if (buffer)
        *buffer = nullptr;
    if (size)
        *size = 0;
    return guarded(err, [&] {
        if (!buffer || !size)
            fail(VDBS_ERR_INTERNAL, "vdbio_lit_vec3_nanovdb: NULL argument");
        const Vec3SGrid &g = lit_typed<Vec3SGrid>(lit, grid, "vec3s");
        copy_nanovdb(nanovdb::openToNanoVDB(g), buffer, size);
    });
}

vdbs_status vdbio_lit_float_nanovdb(const vdbio_lit *lit, const char *grid, void **buffer,
                                    size_t *size, vdbs_error *err)
{
    if (buffer)
        *buffer = nullptr;
    if (size)
        *size = 0;
    return guarded(err, [&] {
        if (!buffer || !size)
            fail(VDBS_ERR_INTERNAL, "vdbio_lit_float_nanovdb: NULL argument");
        const FloatGrid &g = lit_typed<FloatGrid>(lit, grid, "float");
        copy_nanovdb(nanovdb::openToNanoVDB(g), buffer, size);
    });
}

vdbs_status vdbio_lit_transform(const vdbio_lit *lit, const char *grid, vdbio_transform *out,
                                vdbs_error *err)
{
    return guarded(err, [&] {
        if (!lit || !grid || !out)
            fail(VDBS_ERR_INTERNAL, "vdbio_lit_transform: NULL argument");
        const GridBase *g = lit_find(lit, grid);
        if (!g)
            fail(VDBS_ERR_INPUT, format("%s: no grid named \"%s\"", lit->path.c_str(), grid));
        *out = transform_to_c(g->transform());
    });
}

const char *vdbio_lit_meta(const vdbio_lit *lit, const char *key)
{
    if (!lit || !key)
        return nullptr;
    const auto it = lit->meta.find(key);
    return it == lit->meta.end() ? nullptr : it->second.c_str();
}

void vdbio_lit_close(vdbio_lit *lit)
{
    delete lit;
}

vdbs_status vdbio_debug_write_float_grid(const char *path, const char *grid_name,
                                         const float *values, const int dims[3],
                                         const int origin[3], float background, int flags,
                                         vdbs_error *err)
{
    return guarded(err, [&] {
        if (!path || (!values) != (!dims))
            fail(VDBS_ERR_INTERNAL, "vdbio_debug_write_float_grid: NULL argument");
        if (!values) {
            std::ofstream os(path, std::ios::out | std::ios::binary | std::ios::trunc);
            Writer().write_to(os, openvdb::GridCPtrVec(), openvdb::MetaMap());
            os.close();
            if (os.fail())
                fail(VDBS_ERR_IO, format("%s: write failed", path));
            return;
        }
        FloatGrid::Ptr grid = FloatGrid::create(background);
        grid->setName(grid_name ? grid_name : "density");
        grid->setGridClass((flags & VDBIO_DEBUG_LEVEL_SET) ? openvdb::GRID_LEVEL_SET
                                                           : openvdb::GRID_FOG_VOLUME);
        if (flags & VDBIO_DEBUG_FRUSTUM)
            grid->setTransform(openvdb::math::Transform::createFrustumTransform(
                openvdb::BBoxd(openvdb::Vec3d(0.0), openvdb::Vec3d(dims[0], dims[1], dims[2])), 0.5,
                1.0, 1.0));
        const Coord o = origin ? Coord(origin[0], origin[1], origin[2]) : Coord(0);
        auto acc = grid->getAccessor();
        size_t n = 0;
        for (int k = 0; k < dims[2]; ++k)
            for (int j = 0; j < dims[1]; ++j)
                for (int i = 0; i < dims[0]; ++i)
                    acc.setValueOn(o + Coord(i, j, k), values[n++]);
        GridBase::Ptr out = grid;
        if (flags & VDBIO_DEBUG_DOUBLE) {
            auto d =
                openvdb::DoubleGrid::create(std::make_shared<openvdb::DoubleTree>(grid->tree()));
            d->insertMeta(*grid);
            d->setTransform(grid->transform().copy());
            out = d;
        }
        std::ofstream os(path, std::ios::out | std::ios::binary | std::ios::trunc);
        if (!os)
            fail(VDBS_ERR_IO, format("%s: cannot create: %s", path, strerror(errno)));
        Writer().write_to(os, openvdb::GridCPtrVec{out}, openvdb::MetaMap());
        os.close();
        if (os.fail())
            fail(VDBS_ERR_IO, format("%s: write failed", path));
    });
}

} /* extern "C" */
