/* OpenEXR reading through the C++ Imf library, for environment maps and for every image
 * vdbs_image_read meets (compare): a bridge like vdbio.cpp; every exception is caught here
 * and turned into a vdbs_error.
 *
 * Why Imf and not OpenEXRCore (which image.c still uses to write the renders' own files):
 * Core 3.1.5 cannot decompress DWAA/DWAB, the codec many HDRI tools pick, and its decoder has
 * fast paths that mis-order or crash on some layouts (four half channels into float
 * outputs: a half RGBA ZIP file, the most common layout, segfaulted `compare`).
 * Imf::InputFile with a FrameBuffer of FLOAT slices converts half and uint, reads level 0
 * of tiled, mipmapped and ripmapped files and knows every compression, so every EXR takes
 * one path. */
#include "io/exrmap.h"

#include "contain_tbb.h"

#include <ImathBox.h>
#include <ImfArray.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfPartType.h>
#include <ImfRgbaFile.h>

#include <cstdio>
#include <cstring>
#include <new>
#include <set>
#include <string>
#include <vector>

#include <unistd.h>

namespace
{

/* A refusal with its message (the file name is added by the caller). */
struct Refusal {
    std::string message;
};

/* Library messages may span lines; an error is one line. */
std::string one_line(const char *text)
{
    std::string s;
    for (const char *p = text; *p; ++p)
        s += (*p == '\n' || *p == '\r' || *p == '\t') ? ' ' : *p;
    while (!s.empty() && s.back() == ' ')
        s.pop_back();
    return s;
}

std::string channel_names(const Imf::ChannelList &channels)
{
    std::string names;
    int count = 0;
    for (auto it = channels.begin(); it != channels.end(); ++it, ++count) {
        if (count == 16) {
            names += ", ...";
            break;
        }
        names += (count ? ", " : "") + std::string(it.name());
    }
    return count ? names : std::string("none");
}

void require_full_resolution(const Imf::ChannelList &channels, const std::string &name)
{
    const Imf::Channel *c = channels.findChannel(name);
    if (c->xSampling != 1 || c->ySampling != 1)
        throw Refusal{"channel " + name + " is subsampled (" + std::to_string(c->xSampling) + "x" +
                      std::to_string(c->ySampling) + ")"};
}

/* Which channels make the map: "R", "G", "B" with a layer prefix ("" or "layer."), or grey
 * from "Y", or luminance/chroma. With se_layer set the layer "se" holds standard errors and
 * is never taken for the colour. */
struct Choice {
    std::string prefix;
    bool grey = false, chroma = false;
};

Choice choose_channels(const Imf::ChannelList &channels, bool se_layer)
{
    auto has = [&](const std::string &n) { return channels.findChannel(n) != nullptr; };
    Choice choice;
    if (has("R") && has("G") && has("B")) {
        for (const char *n : {"R", "G", "B"})
            require_full_resolution(channels, n);
        return choice;
    }
    if (has("Y")) {
        choice.chroma = has("RY") && has("BY"); /* RgbaInputFile handles the subsampling */
        choice.grey = !choice.chroma;
        if (choice.grey)
            require_full_resolution(channels, "Y");
        return choice;
    }
    std::set<std::string> layers, rgb_layers;
    channels.layers(layers);
    for (const std::string &l : layers)
        if (!(se_layer && l == "se") && has(l + ".R") && has(l + ".G") && has(l + ".B"))
            rgb_layers.insert(l);
    if (rgb_layers.size() == 1) {
        choice.prefix = *rgb_layers.begin() + ".";
        for (const char *n : {"R", "G", "B"})
            require_full_resolution(channels, choice.prefix + n);
        return choice;
    }
    throw Refusal{std::string(rgb_layers.empty() ? "no R, G, B or Y channels"
                                                 : "several layers with R, G, B and no plain "
                                                   "R, G, B") +
                  " (channels: " + channel_names(channels) + ")"};
}

/* The one place pixels are read: the named channels of the data window dw, converted to
 * float, in one pass over the file. Channel names[k] lands in the float plane dst[k] with a
 * stride of `stride` floats per texel, row 0 (dw.min.y) first, no gaps between rows. */
void read_float_planes(Imf::InputFile &file, const Imath::Box2i &dw,
                       const std::vector<std::string> &names, const std::vector<float *> &dst,
                       size_t stride)
{
    const size_t xs = stride * sizeof(float);
    const size_t ys = xs * (size_t)(dw.max.x - dw.min.x + 1);
    Imf::FrameBuffer fb;
    for (size_t k = 0; k < names.size(); ++k)
        fb.insert(names[k], Imf::Slice::Make(Imf::FLOAT, dst[k], dw, xs, ys));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
}

/* The image is the data window: OpenEXR's own lat-long functions (ImfEnvmap.h) are defined
 * on it, and the display window of a map is often a crop or overscan frame nobody means as
 * the sphere. compare, too, matches data windows pixel for pixel (of the same size,
 * wherever they sit). */
Imath::Box2i image_window(const Imf::Header &header)
{
    if (header.hasType() && Imf::isDeepData(header.type()))
        throw Refusal{"deep OpenEXR images are not supported"};
    const Imath::Box2i dw = header.dataWindow();
    const long long w64 = (long long)dw.max.x - dw.min.x + 1;
    const long long h64 = (long long)dw.max.y - dw.min.y + 1;
    if (w64 <= 0 || h64 <= 0 || w64 > (1 << 24) || h64 > (1 << 24))
        throw Refusal{"data window " + std::to_string(w64) + "x" + std::to_string(h64) +
                      " is unusable"};
    return dw;
}

const char *const se_names[3] = {"se.R", "se.G", "se.B"};

/* Whether the standard errors are read: wanted and all three channels present. */
bool with_standard_errors(const Imf::ChannelList &channels, bool want_se)
{
    bool with_se = want_se;
    for (const char *n : se_names)
        with_se = with_se && channels.findChannel(n) != nullptr;
    if (with_se)
        for (const char *n : se_names)
            require_full_resolution(channels, n);
    return with_se;
}

/* Luminance/chroma (Y, RY, BY) into image->rgb: RgbaInputFile reconstructs RGB as half. */
void read_chroma(const char *path, const Imath::Box2i &dw, vdbs_image *image)
{
    const int w = image->width, h = image->height;
    Imf::RgbaInputFile rgba(path);
    Imf::Array2D<Imf::Rgba> pixels(h, w);
    rgba.setFrameBuffer(&pixels[0][0] - (ptrdiff_t)dw.min.x - (ptrdiff_t)dw.min.y * (ptrdiff_t)w, 1,
                        (size_t)w);
    rgba.readPixels(dw.min.y, dw.max.y);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float *t = image->rgb + 3 * ((size_t)y * w + x);
            t[0] = pixels[y][x].r;
            t[1] = pixels[y][x].g;
            t[2] = pixels[y][x].b;
        }
}

/* The chosen channels (and the standard errors) into the allocated image. */
void read_pixels(const char *path, Imf::InputFile &file, const Imath::Box2i &dw,
                 const Choice &choice, bool with_se, vdbs_image *image)
{
    std::vector<std::string> names;
    std::vector<float *> planes;
    if (choice.chroma) {
        read_chroma(path, dw, image);
    } else if (choice.grey) {
        names.push_back("Y");
        planes.push_back(image->rgb);
    } else {
        const char *rgb[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c) {
            names.push_back(choice.prefix + rgb[c]);
            planes.push_back(image->rgb + c);
        }
    }
    for (int c = 0; with_se && c < 3; ++c) {
        names.push_back(se_names[c]);
        planes.push_back(image->se + c);
    }
    if (!names.empty())
        read_float_planes(file, dw, names, planes, 3);
    const size_t texels = (size_t)image->width * (size_t)image->height;
    if (choice.grey)
        for (size_t i = 0; i < texels; ++i)
            image->rgb[3 * i + 1] = image->rgb[3 * i + 2] = image->rgb[3 * i];
}

/* Both public readers: the colour channels choose_channels picks and, when want_se is set
 * and all three are present, se.R, se.G, se.B. */
vdbs_status read_exr(const char *path, vdbs_image *image, bool want_se, vdbs_error *err)
{
    std::memset(image, 0, sizeof *image);
    try {
        Imf::InputFile file(path);
        const Imf::Header &header = file.header();
        const Imath::Box2i dw = image_window(header);
        const Imf::ChannelList &channels = header.channels();
        const Choice choice = choose_channels(channels, want_se);
        const bool with_se = with_standard_errors(channels, want_se);
        vdbs_status st =
            vdbs_image_alloc(image, dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1, with_se, err);
        if (st != VDBS_OK) {
            const std::string why = err ? err->message : "";
            return vdbs_error_set(err, st, "%s: %s", path, why.c_str());
        }
        read_pixels(path, file, dw, choice, with_se, image);
        return VDBS_OK;
    } catch (const Refusal &r) {
        vdbs_image_free(image);
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: %s", path, r.message.c_str());
    } catch (const std::bad_alloc &) {
        vdbs_image_free(image);
        return vdbs_error_set(err, VDBS_ERR_NOMEM, "%s: out of memory reading the OpenEXR file",
                              path);
    } catch (const std::exception &e) {
        vdbs_image_free(image);
        return vdbs_error_set(err, VDBS_ERR_INPUT,
                              "%s: unreadable, corrupt or truncated OpenEXR "
                              "file: %s",
                              path, one_line(e.what()).c_str());
    } catch (...) {
        vdbs_image_free(image);
        return vdbs_error_set(err, VDBS_ERR_INPUT, "%s: unreadable OpenEXR file", path);
    }
}

/* read_exr in a contained child (contain.h): a crash inside OpenEXR on a hostile file
 * becomes an input error. The child writes status, message, then width, height, whether
 * there are standard errors and the pixels; the parent copies them (one memory copy). */
struct Job {
    const char *path;
    bool want_se;
};

struct ResultHead {
    int32_t status;
    int32_t width, height, with_se;
    char message[VDBS_ERROR_MAX];
};

int read_exr_child(int fd, void *user)
{
    const Job &job = *static_cast<const Job *>(user);
    vdbs_image image;
    vdbs_error e;
    ResultHead head;
    std::memset(&head, 0, sizeof head);
    head.status = read_exr(job.path, &image, job.want_se, &e);
    if (head.status != VDBS_OK) {
        std::memcpy(head.message, e.message, sizeof head.message);
        return vdbs_contain_write(fd, &head, sizeof head) == 0 ? 0 : 3;
    }
    head.width = image.width;
    head.height = image.height;
    head.with_se = image.se != nullptr;
    const size_t bytes = (size_t)image.width * (size_t)image.height * 3 * sizeof(float);
    if (vdbs_contain_write(fd, &head, sizeof head) != 0 ||
        vdbs_contain_write(fd, image.rgb, bytes) != 0 ||
        (image.se && vdbs_contain_write(fd, image.se, bytes) != 0))
        return 3;
    return 0;
}

vdbs_status read_exr_contained(const char *path, vdbs_image *image, bool want_se, vdbs_error *err)
{
    std::memset(image, 0, sizeof *image);
    Job job{path, want_se};
    vdbs_contained contained;
    vdbs_status st =
        contain_run_without_tbb_workers(path, "OpenEXR", read_exr_child, &job, &contained, err);
    if (st != VDBS_OK)
        return st;
    const size_t size = contained.size;
    const char *data = contained.data;
    ResultHead head;
    if (!data || size < sizeof head) {
        st = vdbs_error_set(err, VDBS_ERR_INTERNAL, "%s: the OpenEXR reader gave no result", path);
    } else {
        std::memcpy(&head, data, sizeof head);
        head.message[sizeof head.message - 1] = '\0';
        const size_t bytes = (size_t)head.width * (size_t)head.height * 3 * sizeof(float);
        if (head.status != VDBS_OK) {
            st = vdbs_error_set(err, (vdbs_status)head.status, "%s", head.message);
        } else if (size != sizeof head + bytes * (head.with_se ? 2 : 1)) {
            st = vdbs_error_set(err, VDBS_ERR_INTERNAL, "%s: the OpenEXR reader's result is short",
                                path);
        } else if ((st = vdbs_image_alloc(image, head.width, head.height, head.with_se, err)) ==
                   VDBS_OK) {
            std::memcpy(image->rgb, data + sizeof head, bytes);
            if (head.with_se)
                std::memcpy(image->se, data + sizeof head + bytes, bytes);
        }
    }
    vdbs_contain_free(&contained);
    return st;
}

} // namespace

extern "C" vdbs_status vdbs_exrmap_read(const char *path, vdbs_image *image, vdbs_error *err)
{
    return read_exr_contained(path, image, false, err);
}

extern "C" vdbs_status vdbs_exrimage_read(const char *path, vdbs_image *image, vdbs_error *err)
{
    return read_exr_contained(path, image, true, err);
}
