/* Test-only OpenEXR writer (exrwrite.h): every exception is caught and returned as text. */
#include "exrwrite.h"

#include <ImathBox.h>
#include <ImfArray.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfRgbaFile.h>
#include <ImfTiledOutputFile.h>
#include <half.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{

char message[1024];

Imf::Compression compression_of(const std::string &name)
{
    const char *names[] = {"none",  "rle", "zips", "zip",  "piz",
                           "pxr24", "b44", "b44a", "dwaa", "dwab"};
    for (int i = 0; i < 10; ++i)
        if (name == names[i])
            return Imf::Compression(i);
    throw std::runtime_error("unknown compression " + name);
}

/* One channel's pixels of a window in the channel's type. */
struct Plane {
    std::vector<char> bytes;
    size_t size = 0;
};

Plane make_plane(Imf::PixelType type, const float *values, size_t n)
{
    Plane p;
    p.size = type == Imf::HALF ? 2 : 4;
    p.bytes.assign(n * p.size, 0);
    for (size_t i = 0; values && i < n; ++i) {
        char *dst = p.bytes.data() + i * p.size;
        if (type == Imf::HALF) {
            half h(values[i]);
            std::memcpy(dst, &h, 2);
        } else if (type == Imf::FLOAT) {
            std::memcpy(dst, &values[i], 4);
        } else {
            uint32_t u = (uint32_t)values[i];
            std::memcpy(dst, &u, 4);
        }
    }
    return p;
}

void write(const char *path, const test_exr_spec *spec, const float *const *planes)
{
    const int *d = spec->data_window, *s = spec->display_window;
    const Imath::Box2i dw(Imath::V2i(d[0], d[1]), Imath::V2i(d[2], d[3]));
    const bool same = !s[0] && !s[1] && !s[2] && !s[3];
    const Imath::Box2i disp =
        same ? dw : Imath::Box2i(Imath::V2i(s[0], s[1]), Imath::V2i(s[2], s[3]));
    Imf::Header header(disp, dw);
    header.compression() = compression_of(spec->compression);
    const int w = d[2] - d[0] + 1, h = d[3] - d[1] + 1;
    const size_t n = (size_t)w * h;

    if (std::string(spec->channels) == "YC") {
        Imf::Array2D<Imf::Rgba> px(h, w);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                size_t i = (size_t)y * w + x;
                px[y][x] = Imf::Rgba(planes[0][i], planes[1][i], planes[2][i], 1.0f);
            }
        Imf::RgbaOutputFile out(path, header, Imf::WRITE_YC);
        out.setFrameBuffer(&px[0][0] - (ptrdiff_t)d[0] - (ptrdiff_t)d[1] * w, 1, (size_t)w);
        out.writePixels(h);
        return;
    }

    const std::string t = spec->type;
    const Imf::PixelType type = t == "half" ? Imf::HALF : t == "float" ? Imf::FLOAT : Imf::UINT;
    std::vector<std::string> names;
    std::stringstream list(spec->channels);
    for (std::string name; std::getline(list, name, ',');) {
        names.push_back(name);
        header.channels().insert(name, Imf::Channel(type));
    }
    std::vector<Plane> data;
    for (size_t c = 0; c < names.size(); ++c)
        data.push_back(make_plane(type, planes[c], n));
    auto frame = [&](std::vector<Plane> &ps, const Imath::Box2i &win) {
        Imf::FrameBuffer fb;
        const size_t row = (size_t)(win.max.x - win.min.x + 1);
        for (size_t c = 0; c < names.size(); ++c)
            fb.insert(names[c], Imf::Slice::Make(type, ps[c].bytes.data(), win, ps[c].size,
                                                 ps[c].size * row));
        return fb;
    };
    if (!spec->tiles) {
        Imf::OutputFile out(path, header);
        out.setFrameBuffer(frame(data, dw));
        out.writePixels(h);
        return;
    }
    const std::string mode = spec->tiles;
    header.setTileDescription(Imf::TileDescription(16, 16,
                                                   mode == "mip"   ? Imf::MIPMAP_LEVELS
                                                   : mode == "rip" ? Imf::RIPMAP_LEVELS
                                                                   : Imf::ONE_LEVEL));
    Imf::TiledOutputFile out(path, header);
    for (int ly = 0; ly < out.numYLevels(); ++ly)
        for (int lx = 0; lx < out.numXLevels(); ++lx) {
            if (mode == "mip" && lx != ly)
                continue;
            const Imath::Box2i win = out.dataWindowForLevel(lx, ly);
            std::vector<Plane> black;
            const size_t m = (size_t)(win.max.x - win.min.x + 1) * (win.max.y - win.min.y + 1);
            for (size_t c = 0; c < names.size(); ++c)
                black.push_back(make_plane(type, nullptr, m));
            out.setFrameBuffer(frame(lx == 0 && ly == 0 ? data : black, win));
            out.writeTiles(0, out.numXTiles(lx) - 1, 0, out.numYTiles(ly) - 1, lx, ly);
        }
}

} // namespace

extern "C" const char *test_exr_write(const char *path, const test_exr_spec *spec,
                                      const float *const *planes)
{
    try {
        write(path, spec, planes);
        return nullptr;
    } catch (const std::exception &e) {
        std::snprintf(message, sizeof message, "%s: %s", path, e.what());
    } catch (...) {
        std::snprintf(message, sizeof message, "%s: unknown exception", path);
    }
    return message;
}

extern "C" float test_exr_half(float v)
{
    return (float)half(v);
}
