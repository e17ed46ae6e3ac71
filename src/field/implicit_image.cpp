// Volumetric image stacks (implicit_image.hpp): PNG sheets decoded with libpng, sampled per the
// 3MF Volumetric & Implicit Extension v1.0, Part I §2.2 (functionfromimage3d) and ch. 3 (image3d).
#include "implicit_image.hpp"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace trellis::implicit {

namespace {

// ---------------------------------------------------------------- PNG sheets

struct PngInput {
  const std::string* bytes;
  std::size_t at = 0;
  char message[256] = "";
};

void on_read(png_structp p, png_bytep out, png_size_t n) {
  auto* in = static_cast<PngInput*>(png_get_io_ptr(p));
  if (n > in->bytes->size() - in->at) png_error(p, "the file ends early");
  std::memcpy(out, in->bytes->data() + in->at, n);
  in->at += n;
}

void on_error(png_structp p, png_const_charp message) {
  auto* in = static_cast<PngInput*>(png_get_error_ptr(p));
  std::snprintf(in->message, sizeof in->message, "%s", message);
  png_longjmp(p, 1);
}

void on_warning(png_structp, png_const_charp) {}

struct Sheet {
  int width = 0, height = 0, channels = 0, bits = 0;
  std::vector<std::uint16_t> values;  // row by row from the top, channels interleaved
};

// Decodes a PNG into `s` (palette → RGB, transparency → alpha, grey below 8 bits → 8 bits,
// which keeps value / (2^N − 1)); no gamma is applied: the samples are data, not colours.
// `width` and `height` are what the sheet must measure (checked before the pixels are read).
// Returns the problem, empty when decoded. libpng reports errors by longjmp back here: between
// setjmp and the end only C calls and objects owned by the caller are touched.
std::string decode_png(const std::string& bytes, int width, int height, Sheet& s) {
  if (bytes.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) != 0)
    return "is not a PNG file";
  PngInput in{&bytes};
  png_structp p = png_create_read_struct(PNG_LIBPNG_VER_STRING, &in, on_error, on_warning);
  if (!p) return "cannot be decoded (out of memory)";
  png_infop info = png_create_info_struct(p);
  std::vector<png_bytep> rows;
  std::vector<png_byte> pixels;
  if (setjmp(png_jmpbuf(p))) {
    png_destroy_read_struct(&p, &info, nullptr);
    return std::string("is a broken PNG: ") + in.message;
  }
  if (!info) png_error(p, "out of memory");
  png_set_read_fn(p, &in, on_read);
  png_read_info(p, info);
  const png_uint_32 w = png_get_image_width(p, info), h = png_get_image_height(p, info);
  if (w != static_cast<png_uint_32>(width) || h != static_cast<png_uint_32>(height)) {
    png_destroy_read_struct(&p, &info, nullptr);
    char b[160];
    std::snprintf(b, sizeof b, "is %u × %u pixels, not columncount × rowcount = %d × %d", w, h,
                  width, height);
    return b;
  }
  const int type = png_get_color_type(p, info);
  if (type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(p);
  if (type == PNG_COLOR_TYPE_GRAY && png_get_bit_depth(p, info) < 8)
    png_set_expand_gray_1_2_4_to_8(p);
  if (png_get_valid(p, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(p);
  png_set_interlace_handling(p);
  png_read_update_info(p, info);
  s.width = width, s.height = height;
  s.channels = png_get_channels(p, info);
  s.bits = png_get_bit_depth(p, info);
  const std::size_t stride = png_get_rowbytes(p, info);
  pixels.resize(stride * h);
  rows.resize(h);
  for (png_uint_32 r = 0; r < h; ++r) rows[r] = pixels.data() + r * stride;
  png_read_image(p, rows.data());
  png_read_end(p, nullptr);
  png_destroy_read_struct(&p, &info, nullptr);
  const std::size_t n = static_cast<std::size_t>(w) * h * static_cast<std::size_t>(s.channels);
  s.values.resize(n);
  for (png_uint_32 r = 0; r < h; ++r) {
    const png_byte* row = rows[r];
    std::uint16_t* out = s.values.data() + static_cast<std::size_t>(r) * w * s.channels;
    const std::size_t m = static_cast<std::size_t>(w) * static_cast<std::size_t>(s.channels);
    for (std::size_t i = 0; i < m; ++i)
      out[i] = s.bits == 16 ? static_cast<std::uint16_t>(row[2 * i] << 8 | row[2 * i + 1]) : row[i];
  }
  return {};
}

long long positive(const Ctx& c, const El& e, const char* attr) {
  const double v = number(c, e, attr);
  if (!(v >= 1 && v <= 1 << 30) || v != std::floor(v))
    c.fail(e, fmt::format("<{}> {}={} is not a positive integer of at most 1024³ (Part I §3.2)",
                          e.name, attr, v));
  return static_cast<long long>(v);
}

// ---------------------------------------------------------------- sampling

double tiled(Tile t, double s) {  // Part I §2.2's formulas
  switch (t) {
    case Tile::Wrap:
      return s - std::floor(s);
    case Tile::Mirror:
      return 1 - std::abs(s - 2 * std::floor(s / 2) - 1);
    case Tile::Clamp:
      break;
  }
  return std::min(1.0, std::max(0.0, s));
}

// A voxel index one past either end of the grid (linear filtering's neighbours) mapped back in:
// the next tile's first voxel (wrap), the same voxel reflected (mirror), the edge (clamp).
int inside(Tile t, long i, int n) {
  if (i >= 0 && i < n) return static_cast<int>(i);
  if (t == Tile::Wrap) return static_cast<int>(((i % n) + n) % n);
  if (t == Tile::Mirror) i = i < 0 ? -i - 1 : 2L * n - 1 - i;
  return static_cast<int>(std::clamp(i, 0L, static_cast<long>(n) - 1));
}

Tile tile_style(const Ctx& c, const El& e, const char* attr) {
  const char* s = e.attr(attr);
  if (!s || std::string(s) == "wrap") return Tile::Wrap;
  if (std::string(s) == "mirror") return Tile::Mirror;
  if (std::string(s) == "clamp") return Tile::Clamp;
  c.fail(e,
         fmt::format("<{}> {}=\"{}\" is not wrap, mirror or clamp (Part I §2.2)", e.name, attr, s));
}

}  // namespace

void Image3d::rgba(int i, int j, int k, double out[4]) const {
  const std::size_t at = ((static_cast<std::size_t>(k) * static_cast<std::size_t>(rows) +
                           static_cast<std::size_t>(i)) *
                              static_cast<std::size_t>(columns) +
                          static_cast<std::size_t>(j)) *
                         static_cast<std::size_t>(channels);
  const std::uint16_t* v = data.data() + at;
  if (channels <= 2) {
    out[0] = out[1] = out[2] = v[0] / max;
    out[3] = channels == 2 ? v[1] / max : 1.0;
  } else {
    for (int c = 0; c < 3; ++c) out[c] = v[c] / max;
    out[3] = channels == 4 ? v[3] / max : 1.0;
  }
}

std::shared_ptr<const Image3d> read_image3d(const Ctx& c, const El& image3d, const PartReader& part,
                                            const RelatedPart& related) {
  const El* stack = child(image3d, "imagestack");
  if (!stack)
    c.fail(image3d, "<image3d> has no <imagestack>, the one representation Part I §3.1 defines");
  auto img = std::make_shared<Image3d>();
  img->rows = static_cast<int>(positive(c, *stack, "rowcount"));
  img->columns = static_cast<int>(positive(c, *stack, "columncount"));
  img->sheets = static_cast<int>(positive(c, *stack, "sheetcount"));
  if (static_cast<double>(img->rows) * img->columns * img->sheets > kMaxImageSamples)
    c.fail(*stack, fmt::format("the image stack has {} × {} × {} voxels: more than the {:.3g} "
                               "this reader holds",
                               img->columns, img->rows, img->sheets, kMaxImageSamples));
  std::vector<const El*> sheets;
  for (const auto& k : stack->kids)
    if (k->name == "imagesheet") sheets.push_back(k.get());
  if (sheets.size() != static_cast<std::size_t>(img->sheets))
    c.fail(*stack, fmt::format("<imagestack> has {} <imagesheet>s, sheetcount says {} (Part I "
                               "§3.2: exactly sheetcount)",
                               sheets.size(), img->sheets));
  int bits = 0;
  for (std::size_t k = 0; k < sheets.size(); ++k) {
    const El& e = *sheets[k];
    const char* path = e.attr("path");
    if (!path) c.fail(e, "<imagesheet> has no path");
    const auto bytes = part(path);
    if (!bytes) c.fail(e, fmt::format("sheet {}: the package has no part {}", k, path));
    if (!related(path))
      c.fail(e, fmt::format("sheet {}: the part {} has no 3D Texture relationship from the model "
                            "part {} (Part I §3.2.2: each sheet MUST have one); add <Relationship "
                            "Type=\"{}\" Target=\"{}\" Id=\"…\"/> to its .rels part",
                            k, path, c.part, kTextureRelationship, path));
    Sheet s;
    const std::string why = decode_png(*bytes, img->columns, img->rows, s);
    if (!why.empty()) c.fail(e, fmt::format("sheet {} ({}) {}", k, path, why));
    if (k == 0) {
      img->channels = s.channels, bits = s.bits;
      img->max = s.bits == 16 ? 65535.0 : 255.0;
      if (static_cast<double>(s.values.size()) * img->sheets > kMaxImageSamples)
        c.fail(*stack,
               fmt::format("the image stack holds more than {:.3g} values", kMaxImageSamples));
      img->data.reserve(s.values.size() * static_cast<std::size_t>(img->sheets));
    } else if (s.channels != img->channels || s.bits != bits) {
      c.fail(e, fmt::format("sheet {} ({}) has {} channel(s) of {} bits, sheet 0 {} of {}: the "
                            "sheets of a stack share one pixel layout and bit depth (Part I §3.2)",
                            k, path, s.channels, s.bits, img->channels, bits));
    }
    img->data.insert(img->data.end(), s.values.begin(), s.values.end());
  }
  return img;
}

ImageFunction image_function(
    const Ctx& c, const El& fn,
    const std::function<std::shared_ptr<const Image3d>(long long)>& image) {
  ImageFunction f;
  f.image = image(resource_id(c, fn, fn.attr("image3dID") ? "image3dID" : "image3did"));
  const char* filter = fn.attr("filter");
  if (filter && std::string(filter) == "nearest")
    f.filter = Filter::Nearest;
  else if (filter && std::string(filter) != "linear")
    c.fail(fn, fmt::format("<functionfromimage3d> filter=\"{}\" is not linear or nearest (Part I "
                           "§2.2)",
                           filter));
  f.tile[0] = tile_style(c, fn, "tilestyleu");
  f.tile[1] = tile_style(c, fn, "tilestylev");
  f.tile[2] = tile_style(c, fn, "tilestylew");
  f.offset = number(c, fn, fn.attr("valueoffset") ? "valueoffset" : "offset", 0.0);
  f.scale = number(c, fn, fn.attr("valuescale") ? "valuescale" : "scale", 1.0);
  return f;
}

// Part I §2.2 and §3.2: u runs along the columns, v up the rows (row 0 at v = 1), w up the
// sheets; voxel centres at (index + ½) / count. "nearest" takes the voxel whose centre is closest,
// the lower index on a tie (Figure 2-3); "linear" interpolates the eight centres around uvw, the
// neighbours past an edge given by the tile style.
void ImageFunction::sample(const double uvw[3], double out[4]) const {
  if (!std::isfinite(uvw[0]) || !std::isfinite(uvw[1]) || !std::isfinite(uvw[2])) {
    std::fill(out, out + 4, std::nan(""));
    return;
  }
  const Image3d& im = *image;
  const int n[3] = {im.columns, im.rows, im.sheets};
  double x[3];
  for (int a = 0; a < 3; ++a) x[a] = tiled(tile[a], uvw[a]) * n[a] - 0.5;
  // Axis v counts up from the bottom here; the row index counts down from the top.
  auto row = [&](long b) { return im.rows - 1 - inside(tile[1], b, im.rows); };
  if (filter == Filter::Nearest) {
    const int j = inside(Tile::Clamp, static_cast<long>(std::ceil(x[0] - 0.5)), n[0]);
    const int i =
        im.rows - 1 - inside(Tile::Clamp, static_cast<long>(std::floor(x[1] + 0.5)), n[1]);
    const int k = inside(Tile::Clamp, static_cast<long>(std::ceil(x[2] - 0.5)), n[2]);
    im.rgba(i, j, k, out);
  } else {
    long lo[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = static_cast<long>(std::floor(x[a]));
      t[a] = x[a] - static_cast<double>(lo[a]);
    }
    std::fill(out, out + 4, 0.0);
    for (int corner = 0; corner < 8; ++corner) {
      const int du = corner & 1, dv = (corner >> 1) & 1, dw = corner >> 2;
      const double weight =
          (du ? t[0] : 1 - t[0]) * (dv ? t[1] : 1 - t[1]) * (dw ? t[2] : 1 - t[2]);
      if (weight == 0) continue;
      double v[4];
      im.rgba(row(lo[1] + dv), inside(tile[0], lo[0] + du, n[0]), inside(tile[2], lo[2] + dw, n[2]),
              v);
      for (int ch = 0; ch < 4; ++ch) out[ch] += weight * v[ch];
    }
  }
  for (int ch = 0; ch < 4; ++ch) out[ch] = out[ch] * scale + offset;
}

}  // namespace trellis::implicit
