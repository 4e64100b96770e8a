// PNG encoding and decoding (libpng's simplified API; the only file that includes libpng).
#include <png.h>

#include <csetjmp>
#include <vector>

#include "printtwin/report.hpp"

namespace printtwin {

namespace {

struct WriteState {
  std::string* out;
};

void write_to_string(png_structp png, png_bytep data, png_size_t length) {
  auto* st = static_cast<WriteState*>(png_get_io_ptr(png));
  st->out->append(reinterpret_cast<const char*>(data), length);
}

void flush_nothing(png_structp) {}

// libpng reports errors by longjmp; keep the frame with setjmp free of C++ objects.
bool write_png_rows(png_structp png, png_infop info, png_bytepp rows, int width, int height) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
               PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  // Renders are smooth gradients with flat background: "up" + "sub" filters do most of the
  // work, so a low zlib level suffices. The five views of a 200k-triangle part: level 2
  // encodes in ~35 ms (776 kB), level 5 took ~130 ms for 680 kB (bench/report_bench
  // BM_EncodePngs).
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB | PNG_FILTER_UP);
  png_set_compression_level(png, 2);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, info);
  return true;
}

}  // namespace

Result<std::string> encode_png(const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4)
    return internal_error("encode_png: image size does not match its pixel buffer");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (png == nullptr) return internal_error("libpng: cannot create a writer");
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return internal_error("libpng: cannot create an info struct");
  }
  std::string out;
  WriteState st{&out};
  png_set_write_fn(png, &st, write_to_string, flush_nothing);
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  for (int y = 0; y < image.height; ++y)
    rows[static_cast<std::size_t>(y)] =
        const_cast<png_bytep>(image.rgba.data() + static_cast<std::size_t>(y) * image.width * 4);
  const bool ok = write_png_rows(png, info, rows.data(), image.width, image.height);
  png_destroy_write_struct(&png, &info);
  if (!ok) return internal_error("libpng failed to encode the image");
  return out;
}

Result<Image> decode_png(std::string_view png_bytes) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (png_image_begin_read_from_memory(&png, png_bytes.data(), png_bytes.size()) == 0)
    return bad_input(std::string("not a readable PNG: ") + png.message);
  png.format = PNG_FORMAT_RGBA;
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgba.resize(PNG_IMAGE_SIZE(png));
  if (png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr) == 0) {
    png_image_free(&png);
    return bad_input(std::string("corrupt PNG: ") + png.message);
  }
  return image;
}

}  // namespace printtwin
