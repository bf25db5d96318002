// SPDX-License-Identifier: BSD-3-Clause
#include "io/stereo/png_file.hpp"

#include <csetjmp>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <vector>

#include <png.h>

namespace roadpreview {
namespace {

constexpr png_uint_32 kMaxSidePx = 1u << 15;
// Deflate expands at most 1032-fold (zlib's FAQ): pixels that would need more than that of the file's bytes are a
// lying header, refused before anything is allocated for them.
constexpr double kMaxDeflateRatio = 1032.0;

struct Reader {
    std::FILE* file = nullptr;
    png_structp png = nullptr;
    png_infop info = nullptr;
    double file_bytes = 0.0;
    char error[256] = "";
    ~Reader() {
        if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
        if (file) std::fclose(file);
    }
};

// libpng reports errors by longjmp back to the setjmp in read_into; the message is kept for the exception.
void on_error(png_structp png, png_const_charp message) {
    auto* reader = static_cast<Reader*>(png_get_error_ptr(png));
    std::snprintf(reader->error, sizeof reader->error, "%s", message);
    std::longjmp(png_jmpbuf(png), 1);
}
void on_warning(png_structp, png_const_charp) {}

// Everything with a destructor lives in the caller, so the longjmp skips none (C++ [csetjmp.syn]).
bool read_into(Reader& r, cv::Mat& image, std::vector<png_bytep>& rows) {
    if (setjmp(png_jmpbuf(r.png))) return false;
    png_init_io(r.png, r.file);
    png_set_user_limits(r.png, kMaxSidePx, kMaxSidePx);
    png_read_info(r.png, r.info);
    const double stored_bits = double(png_get_image_width(r.png, r.info)) * png_get_image_height(r.png, r.info) *
                               png_get_channels(r.png, r.info) * png_get_bit_depth(r.png, r.info);
    if (stored_bits / 8.0 > kMaxDeflateRatio * r.file_bytes) png_error(r.png, "its size is more than its data holds");
    png_set_palette_to_rgb(r.png);  // RGBA where the palette has transparency
    png_set_expand_gray_1_2_4_to_8(r.png);
    if (png_get_color_type(r.png, r.info) == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_strip_alpha(r.png);
    if (png_get_bit_depth(r.png, r.info) == 16) png_set_swap(r.png);  // PNG is big-endian
    png_set_interlace_handling(r.png);
    png_read_update_info(r.png, r.info);
    const int channels = png_get_channels(r.png, r.info), depth = png_get_bit_depth(r.png, r.info);
    image.create(static_cast<int>(png_get_image_height(r.png, r.info)),
                 static_cast<int>(png_get_image_width(r.png, r.info)),
                 CV_MAKETYPE(depth == 16 ? CV_16U : CV_8U, channels));
    rows.resize(static_cast<std::size_t>(image.rows));
    for (int v = 0; v < image.rows; ++v) rows[static_cast<std::size_t>(v)] = image.ptr(v);
    png_read_image(r.png, rows.data());
    png_read_end(r.png, nullptr);
    return true;
}

}  // namespace

cv::Mat read_png(const std::string& path) {
    Reader r;
    r.file = std::fopen(path.c_str(), "rb");
    if (!r.file) throw std::runtime_error(path + ": cannot read image (missing or unreadable)");
    if (std::fseek(r.file, 0, SEEK_END) == 0) r.file_bytes = static_cast<double>(std::ftell(r.file));
    std::rewind(r.file);
    png_byte signature[8] = {};
    if (std::fread(signature, 1, sizeof signature, r.file) != sizeof signature || png_sig_cmp(signature, 0, 8) != 0)
        throw std::runtime_error(path + ": cannot read image (not a PNG file)");
    r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r, on_error, on_warning);
    if (r.png) r.info = png_create_info_struct(r.png);
    if (!r.png || !r.info) throw std::runtime_error(path + ": cannot read image (libpng could not start)");
    png_set_sig_bytes(r.png, 8);
    cv::Mat image;
    std::vector<png_bytep> rows;
    if (!read_into(r, image, rows))
        throw std::runtime_error(path + ": cannot read image (" + std::string(r.error) + ")");
    return image;
}

}  // namespace roadpreview
