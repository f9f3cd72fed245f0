#include "keyfleet/agent/image_quality.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <numeric>

// The per-frame loops below are plain loops over 8- and 16-bit rows, written so that the
// compiler vectorises them at the baseline instruction set (no intrinsics, no -march).

namespace keyfleet::agent {

double energy_of_laplacian(const cv::Mat& grey) {
  if (grey.type() != CV_8UC1) {  // not what the selector measures: the plain formulation
    static const cv::Mat kernel = (cv::Mat_<float>(3, 3) << 1, 4, 1, 4, -20, 4, 1, 4, 1) / 6.0f;
    cv::Mat response;
    cv::filter2D(grey, response, CV_32F, kernel, {-1, -1}, 0, cv::BORDER_REPLICATE);
    return response.dot(response);
  }
  cv::Mat padded;  // measured at 112 x 112: the copy costs little
  cv::copyMakeBorder(grey, padded, 1, 1, 1, 1, cv::BORDER_REPLICATE);
  double energy = 0;  // of the responses times 6; exact (below 2^53)
  for (int y = 0; y < grey.rows; ++y) {
    const std::uint8_t* up = padded.ptr(y);
    const std::uint8_t* mid = padded.ptr(y + 1);
    const std::uint8_t* down = padded.ptr(y + 2);
    std::int64_t row = 0;
    for (int x = 0; x < grey.cols; ++x) {
      const int r = up[x] + up[x + 2] + down[x] + down[x + 2] +
                    4 * (up[x + 1] + mid[x] + mid[x + 2] + down[x + 1]) - 20 * mid[x + 1];
      row += r * r;  // |r| <= 5100
    }
    energy += double(row);
  }
  return energy / 36;
}

namespace {

// OpenCV's 8-bit BGR -> CIELAB, its L alone, in its fixed-point arithmetic: each channel through
// the sRGB gamma to a linear value x 255 x 8 (rounded), Y as their sum with 12-bit weights
// (rounded), f(Y) (the cube root, or its linear toe below 0.008856) in 15-bit fixed point from a
// table of 3,072 entries, and L = 116 f(Y) - 16 scaled to 0..255 and rounded. cv::cvtColor does
// the same for a and b too, at about 3x the work and through more tables (which fall out of cache
// between an agent's stages); the unit test checks every 8-bit colour against it.
struct LightnessTables {
  static constexpr int kGammaShift = 3, kLabShift = 12, kLabShift2 = 15;
  static constexpr int kYEntries = 256 * 3 / 2 * (1 << kGammaShift);
  std::array<std::uint16_t, 256> linear{};          // sRGB level -> linear x 255 x 8
  std::array<std::uint8_t, kYEntries> lightness{};  // Y index -> L (0..255)
  int weight_b = 0, weight_g = 0, weight_r = 0;     // Y's weights (D65 white: Y_n = 1) x 4096

  LightnessTables() {
    for (int i = 0; i < 256; ++i) {
      const double v = i / 255.0;
      const double linear_v = v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
      linear[std::size_t(i)] = std::uint16_t(cvRound(255.0 * (1 << kGammaShift) * linear_v));
    }
    const int scale = (116 * 255 + 50) / 100;
    const int shift = -((16 * 255 * (1 << kLabShift2) + 50) / 100);
    for (int i = 0; i < kYEntries; ++i) {
      const double y = i / (255.0 * (1 << kGammaShift));
      const double f = y < 0.008856 ? y * 7.787 + 16.0 / 116.0 : std::cbrt(y);
      const int fy = std::min(65535, cvRound((1 << kLabShift2) * f));
      const int l = (scale * fy + shift + (1 << (kLabShift2 - 1))) >> kLabShift2;
      lightness[std::size_t(i)] = std::uint8_t(std::clamp(l, 0, 255));
    }
    weight_r = cvRound((1 << kLabShift) * 0.212671);
    weight_g = cvRound((1 << kLabShift) * 0.715160);
    weight_b = cvRound((1 << kLabShift) * 0.072169);
  }

  std::uint8_t of(std::uint8_t b, std::uint8_t g, std::uint8_t r) const {
    const int y = (linear[b] * weight_b + linear[g] * weight_g + linear[r] * weight_r +
                   (1 << (kLabShift - 1))) >>
                  kLabShift;
    return lightness[std::size_t(y)];
  }
};

const LightnessTables& lightness_tables() {
  static const LightnessTables tables;
  return tables;
}

}  // namespace

std::uint8_t lab_lightness(std::uint8_t b, std::uint8_t g, std::uint8_t r) {
  return lightness_tables().of(b, g, r);
}

double brightness_score(const cv::Mat& bgr) {
  // BGR or BGRA (the fourth channel ignored, as cv::cvtColor does).
  CV_Assert(bgr.depth() == CV_8U && (bgr.channels() == 3 || bgr.channels() == 4));
  const LightnessTables& tables = lightness_tables();
  const int step = bgr.channels();
  std::array<std::int64_t, 256> histogram{};
  for (int y = 0; y < bgr.rows; ++y) {
    const std::uint8_t* p = bgr.ptr(y);
    for (int x = 0; x < bgr.cols; ++x, p += step) ++histogram[tables.of(p[0], p[1], p[2])];
  }
  double sum = 0;
  for (int v = 0; v < 256; ++v) {
    const double centred = v * (100.0 / 255.0) - 50.0;
    sum += double(histogram[std::size_t(v)]) * centred * centred;
  }
  return 1.0 / (1.0 + sum);  // +1: a flat mid-grey frame stays finite
}

namespace {

constexpr double kMinEdgeFraction = 0.02;

inline std::uint8_t min8(std::uint8_t a, std::uint8_t b) { return a < b ? a : b; }
inline std::uint8_t max8(std::uint8_t a, std::uint8_t b) { return a < b ? b : a; }
inline std::uint8_t median8(std::uint8_t a, std::uint8_t b, std::uint8_t c) {
  return max8(min8(a, b), min8(max8(a, b), c));
}

// One output row of the 3x3 median from three rows of the padded image: each column triple is
// sorted once; the median of the nine is then the median of (largest low, median of the
// middles, smallest high).
void median_row(const std::uint8_t* __restrict a, const std::uint8_t* __restrict b,
                const std::uint8_t* __restrict c, int w, std::uint8_t* __restrict lo,
                std::uint8_t* __restrict mid, std::uint8_t* __restrict hi,
                std::uint8_t* __restrict out) {
  for (int x = 0; x < w + 2; ++x) {
    const std::uint8_t l = min8(a[x], b[x]), u = max8(a[x], b[x]);
    lo[x] = min8(l, c[x]);
    hi[x] = max8(u, c[x]);
    mid[x] = max8(l, min8(u, c[x]));
  }
  for (int x = 0; x < w; ++x) {
    const std::uint8_t largest_low = max8(max8(lo[x], lo[x + 1]), lo[x + 2]);
    const std::uint8_t smallest_high = min8(min8(hi[x], hi[x + 1]), hi[x + 2]);
    out[x] = median8(largest_low, median8(mid[x], mid[x + 1], mid[x + 2]), smallest_high);
  }
}

// 3x3 median of `padded` (the image with one replicated pixel around) into `out`, whose
// interior starts at (offset, offset).
void median3x3(const cv::Mat& padded, cv::Mat& out, int offset,
               std::vector<std::uint8_t>& columns) {
  const int w = padded.cols - 2, h = padded.rows - 2, n = w + 2;
  columns.resize(3 * std::size_t(n));
  std::uint8_t* lo = columns.data();
  for (int y = 0; y < h; ++y)
    median_row(padded.ptr(y), padded.ptr(y + 1), padded.ptr(y + 2), w, lo, lo + n, lo + 2 * n,
               out.ptr(y + offset) + offset);
}

// Replicates the interior of `image` (a border of `border` pixels around) into the border.
void replicate_border(cv::Mat& image, int border) {
  const int w = image.cols - 2 * border, h = image.rows - 2 * border;
  for (int y = border; y < border + h; ++y) {
    std::uint8_t* row = image.ptr(y);
    std::fill(row, row + border, row[border]);
    std::fill(row + border + w, row + image.cols, row[border + w - 1]);
  }
  for (int y = 0; y < border; ++y) {
    image.row(border).copyTo(image.row(y));
    image.row(border + h - 1).copyTo(image.row(border + h + y));
  }
}

// Kumar's differences of one row (`c`) from the rows two and one above and below: along x
// |c(x+1) - c(x-1)| and |c(x+2) - 2 c(x) + c(x-2)|, along y the same across rows. In 16 bits
// (at most 510), which the compiler vectorises eight or sixteen pixels at a time.
void difference_row(const std::uint8_t* __restrict up2, const std::uint8_t* __restrict up1,
                    const std::uint8_t* __restrict c, const std::uint8_t* __restrict down1,
                    const std::uint8_t* __restrict down2, int w, std::int16_t* __restrict dx1,
                    std::int16_t* __restrict dx2, std::int16_t* __restrict dy1,
                    std::int16_t* __restrict dy2) {
  for (int x = 0; x < w; ++x) {
    dx1[x] = std::int16_t(max8(c[x + 1], c[x - 1]) - min8(c[x + 1], c[x - 1]));
    dy1[x] = std::int16_t(max8(down1[x], up1[x]) - min8(down1[x], up1[x]));
    const std::int16_t twice = std::int16_t(2 * c[x]);
    const std::int16_t second_x = std::int16_t(c[x + 2] + c[x - 2] - twice);
    const std::int16_t second_y = std::int16_t(down2[x] + up2[x] - twice);
    dx2[x] = std::max(second_x, std::int16_t(-second_x));
    dy2[x] = std::max(second_y, std::int16_t(-second_y));
  }
}

// Sums of three neighbours of a row that carries one reflected value each side.
void row_sums(const std::int16_t* __restrict d, int w, std::int16_t* __restrict out) {
  for (int x = 0; x < w; ++x) out[x] = std::int16_t(d[x] + d[x + 1] + d[x + 2]);
}

// "first > edge contrast" and "second > first * ratio", the latter as the float formulation
// computes it (the float product), in 16-bit integers: for the integer sums `first` (at most
// 9 x 255) the float product's floor is whole * first + (first * fraction) >> 16, checked
// for every possible `first` when the parameters are set; otherwise the float comparison.
struct SharpTest {
  static constexpr int kMaxFirst = 9 * 255;
  std::int16_t threshold = 0, whole = 0;
  std::uint16_t fraction = 0;
  bool integer = false;
  float ratio = 0;

  SharpTest(double edge_contrast, double sharp_ratio) : ratio(float(sharp_ratio)) {
    // The sums are integers: "> edge_contrast" (as a float) is "> its floor".
    threshold = std::int16_t(std::clamp(std::floor(float(edge_contrast)), -1.0f, 32767.0f));
    const double r = ratio;
    if (!(r >= 0 && r * kMaxFirst < 32767)) return;
    whole = std::int16_t(std::floor(r));
    const double ideal = (r - whole) * 65536;
    for (double m = std::floor(ideal) - 1; m <= std::ceil(ideal) + 1 && !integer; ++m) {
      if (m < 0 || m > 65535) continue;
      fraction = std::uint16_t(m);
      integer = true;
      for (int f = 0; f <= kMaxFirst && integer; ++f)
        integer = floor_of_product(f) == int(std::floor(float(f) * ratio));
    }
  }
  int floor_of_product(int first) const {
    return whole * first + int((std::uint32_t(first) * fraction) >> 16);
  }
};

struct SharpCounts {
  int edges_x = 0, sharp_x = 0, edges_y = 0, sharp_y = 0;
};

// Adds one row's counts from the horizontal sums of the rows above, at and below it (each
// four quantities of w: first x, second x, first y, second y).
template <bool kInteger>
void count_row(const std::int16_t* __restrict a, const std::int16_t* __restrict b,
               const std::int16_t* __restrict c, int w, const SharpTest& test,
               SharpCounts& counts) {
  const std::int16_t threshold = test.threshold, whole = test.whole;
  const std::uint16_t fraction = test.fraction;
  const float ratio = test.ratio;
  auto sharp = [&](std::int16_t first, std::int16_t second) {
    if constexpr (kInteger) {
      const auto high = std::uint16_t((std::uint32_t(std::uint16_t(first)) * fraction) >> 16);
      return second > std::int16_t(whole * first + high);
    } else {
      return float(second) > float(first) * ratio;
    }
  };
  // Per row in 16 bits (a row is far narrower than 32767 pixels), added up in int.
  std::int16_t edges_x = 0, sharp_x = 0, edges_y = 0, sharp_y = 0;
  for (int x = 0; x < w; ++x) {
    const std::int16_t first_x = std::int16_t(a[x] + b[x] + c[x]);
    const std::int16_t second_x = std::int16_t(a[w + x] + b[w + x] + c[w + x]);
    const std::int16_t first_y = std::int16_t(a[2 * w + x] + b[2 * w + x] + c[2 * w + x]);
    const std::int16_t second_y = std::int16_t(a[3 * w + x] + b[3 * w + x] + c[3 * w + x]);
    const std::int16_t edge_x = first_x > threshold, edge_y = first_y > threshold;
    edges_x = std::int16_t(edges_x + edge_x);
    edges_y = std::int16_t(edges_y + edge_y);
    sharp_x = std::int16_t(sharp_x + (edge_x & std::int16_t(sharp(first_x, second_x))));
    sharp_y = std::int16_t(sharp_y + (edge_y & std::int16_t(sharp(first_y, second_y))));
  }
  counts.edges_x += edges_x;
  counts.sharp_x += sharp_x;
  counts.edges_y += edges_y;
  counts.sharp_y += sharp_y;
}

// Kumar's counts on `m`, a w x h image with two replicated pixels around: per pixel and
// direction the first difference and the difference of differences, each summed over 3x3
// (reflected border, as cv::boxFilter), then `test`. Rows go through once: differences,
// their horizontal sums into a ring of three rows, then the vertical sums and the counts.
// All sums fit 16 bits (at most 9 x 510).
SharpCounts count_sharp_edges(const cv::Mat& m, int w, int h, const SharpTest& test,
                              std::vector<std::int16_t>& rows) {
  const int stride = w + 2;  // a difference row with one reflected value each side
  rows.resize(4 * std::size_t(stride) + 12 * std::size_t(w));
  std::int16_t* dx1 = rows.data();
  std::int16_t* dx2 = dx1 + stride;
  std::int16_t* dy1 = dx2 + stride;
  std::int16_t* dy2 = dy1 + stride;
  std::int16_t* ring = dy2 + stride;  // 3 slots of 4 horizontal sums (x1, x2, y1, y2) of w

  auto differences = [&](int j) {  // row j of the image into its ring slot
    difference_row(m.ptr(j) + 2, m.ptr(j + 1) + 2, m.ptr(j + 2) + 2, m.ptr(j + 3) + 2,
                   m.ptr(j + 4) + 2, w, dx1 + 1, dx2 + 1, dy1 + 1, dy2 + 1);
    std::int16_t* slot = ring + (j % 3) * 4 * w;
    for (std::int16_t* d : {dx1, dx2, dy1, dy2}) {
      d[0] = d[w > 1 ? 2 : 1];
      d[w + 1] = d[w > 1 ? w - 1 : 1];
      row_sums(d, w, slot);
      slot += w;
    }
  };

  SharpCounts counts;
  differences(0);
  for (int y = 0; y < h; ++y) {
    if (y + 1 < h) differences(y + 1);
    const int above = y > 0 ? y - 1 : std::min(1, h - 1);
    const int below = y + 1 < h ? y + 1 : std::max(h - 2, 0);
    const std::int16_t* a = ring + (above % 3) * 4 * w;
    const std::int16_t* b = ring + (y % 3) * 4 * w;
    const std::int16_t* c = ring + (below % 3) * 4 * w;
    if (test.integer)
      count_row<true>(a, b, c, w, test, counts);
    else
      count_row<false>(a, b, c, w, test, counts);
  }
  return counts;
}

// Fraction of edge pixels that are sharp.
double sharp_fraction(int edges, int sharp, double pixels) {
  if (edges == 0) return 0;
  // A heavily blurred frame keeps few edges, and the few left are noise that looks sharp:
  // below 2 % edge pixels the fraction is scaled down, which keeps the score monotone.
  const double scarcity = std::min(1.0, edges / (kMinEdgeFraction * pixels));
  return double(sharp) / edges * scarcity;
}

}  // namespace

double kumar_sharpness(const cv::Mat& grey, const SharpnessParams& params,
                       SharpnessScratch& scratch) {
  CV_Assert(grey.type() == CV_8UC1);
  if (grey.empty()) return 0;
  const int w = grey.cols, h = grey.rows;
  cv::copyMakeBorder(grey, scratch.padded_grey, 1, 1, 1, 1, cv::BORDER_REPLICATE);
  scratch.median.create(h + 4, w + 4, CV_8UC1);
  median3x3(scratch.padded_grey, scratch.median, 2, scratch.columns);
  replicate_border(scratch.median, 2);
  const SharpTest test(params.edge_contrast, params.sharp_ratio);
  const SharpCounts counts = count_sharp_edges(scratch.median, w, h, test, scratch.rows);
  const double pixels = double(w) * h;
  return std::min(sharp_fraction(counts.edges_x, counts.sharp_x, pixels),
                  sharp_fraction(counts.edges_y, counts.sharp_y, pixels));
}

double kumar_sharpness(const cv::Mat& grey, const SharpnessParams& params) {
  SharpnessScratch scratch;
  return kumar_sharpness(grey, params, scratch);
}

AreaResizer::Taps AreaResizer::taps(int source, int target) {
  // In units of 1/b pixel (s = a / b): source pixel j spans [j b, (j + 1) b), output i spans
  // [i a, (i + 1) a); their overlap is a whole number of units.
  const int g = std::gcd(source, target), a = source / g, b = target / g;
  Taps t;
  t.count = (a + b - 1) / b + 1;  // an interval of a units meets at most ceil(a / b) + 1 pixels
  t.sum = a;
  t.first.resize(std::size_t(target));
  t.overlaps.assign(std::size_t(target) * t.count, 0);
  for (int i = 0; i < target; ++i) {
    const std::int64_t lo = std::int64_t(i) * a, hi = lo + a;
    const int j = int(lo / b);
    t.first[std::size_t(i)] = j;
    for (int k = 0; k < t.count && j + k < source; ++k) {
      const std::int64_t overlap =
          std::min(hi, std::int64_t(j + k + 1) * b) - std::max(lo, std::int64_t(j + k) * b);
      if (overlap > 0) t.overlaps[std::size_t(i) * t.count + k] = std::uint16_t(overlap);
    }
  }
  return t;
}

namespace {

// One output row from the vertical sums of all source columns; kChannels and kCount fixed
// at compile time for the usual cases (the inner loops then unroll), 0 = given at run time.
template <int kChannels, int kCount>
void area_columns(const std::uint16_t* __restrict sums, const std::vector<int>& first,
                  const std::vector<std::uint16_t>& overlaps, int count, int channels,
                  std::uint64_t reciprocal, std::uint32_t half, int width,
                  std::uint8_t* __restrict out) {
  const int cn = kChannels > 0 ? kChannels : channels;
  const int taps = kCount > 0 ? kCount : count;
  const std::uint16_t* __restrict w = overlaps.data();
  const int* __restrict starts = first.data();
  for (int x = 0; x < width; ++x, w += taps) {
    const std::uint16_t* __restrict s = sums + std::size_t(starts[x]) * cn;
    for (int c = 0; c < cn; ++c) {
      std::uint32_t total = half;
      for (int k = 0; k < taps; ++k) total += std::uint32_t(w[k]) * s[k * cn + c];
      out[x * cn + c] = std::uint8_t((total * reciprocal) >> 32);
    }
  }
}

using AreaColumns = void (*)(const std::uint16_t*, const std::vector<int>&,
                             const std::vector<std::uint16_t>&, int, int, std::uint64_t,
                             std::uint32_t, int, std::uint8_t*);

AreaColumns area_columns_for(int channels, int count) {
  if (channels == 3 && count == 3) return area_columns<3, 3>;
  if (channels == 3 && count == 4) return area_columns<3, 4>;
  if (channels == 3 && count == 5) return area_columns<3, 5>;
  if (channels == 1 && count == 3) return area_columns<1, 3>;
  if (channels == 1 && count == 4) return area_columns<1, 4>;
  return area_columns<0, 0>;
}

// Rows j.. of `src` weighted by `overlaps` (zero-padded) into 16-bit sums of n values.
void area_rows(const cv::Mat& src, int j, const std::uint16_t* overlaps, int count, int n,
               std::uint16_t* __restrict sums) {
  const std::uint8_t* __restrict s = src.ptr(j);
  const std::uint16_t w0 = overlaps[0];
  for (int k = 0; k < n; ++k) sums[k] = std::uint16_t(w0 * s[k]);
  for (int t = 1; t < count && overlaps[t] > 0; ++t) {
    const std::uint8_t* __restrict r = src.ptr(j + t);
    const std::uint16_t w = overlaps[t];
    for (int k = 0; k < n; ++k) sums[k] = std::uint16_t(sums[k] + w * r[k]);
  }
}

}  // namespace

void AreaResizer::resize(const cv::Mat& src, cv::Mat& dst, cv::Size size) {
  const bool shrinks = size.width <= src.cols && size.height <= src.rows;
  const bool integer_factors = size.width > 0 && size.height > 0 && src.cols % size.width == 0 &&
                               src.rows % size.height == 0;
  if (src.depth() == CV_8U && src.channels() <= 4 && shrinks && !integer_factors &&
      (src.size() != from_ || size != to_)) {
    x_ = taps(src.cols, size.width);
    y_ = taps(src.rows, size.height);
    from_ = src.size();
    to_ = size;
    // Vertical sums in 16 bits; the rounded quotient by the product of the two unit sums
    // as a multiplication, checked for every total that can occur.
    const std::uint64_t divisor = std::uint64_t(x_.sum) * std::uint64_t(y_.sum);
    exact_ = y_.sum * 255 <= 65535 && divisor * 255 < (1u << 24);
    reciprocal_ = exact_ ? ((std::uint64_t(1) << 32) / divisor + 1) : 0;
    for (std::uint64_t n = 0; exact_ && n <= divisor * 255 + divisor / 2; ++n)
      exact_ = ((n * reciprocal_) >> 32) == n / divisor;
  }
  if (src.depth() != CV_8U || src.channels() > 4 || !shrinks || integer_factors || !exact_) {
    cv::resize(src, dst, size, 0, 0, cv::INTER_AREA);  // OpenCV's fast path for integer factors
    return;
  }
  const int cn = src.channels(), n = src.cols * cn;
  // Zero overlaps may reach past the last column: those sums stay zero.
  rows_.assign((std::size_t(src.cols) + x_.count) * cn, 0);
  dst.create(size, src.type());
  const AreaColumns columns = area_columns_for(cn, x_.count);
  const auto half = std::uint32_t(std::uint64_t(x_.sum) * y_.sum / 2);
  for (int i = 0; i < size.height; ++i) {
    area_rows(src, y_.first[std::size_t(i)], &y_.overlaps[std::size_t(i) * y_.count], y_.count, n,
              rows_.data());
    columns(rows_.data(), x_.first, x_.overlaps, x_.count, cn, reciprocal_, half, size.width,
            dst.ptr(i));
  }
}

void QualityImages::prepare(const cv::Mat& bgr, int size, int sharpness_width) {
  if (sharpness_width < bgr.cols) {
    const double f = double(sharpness_width) / bgr.cols;
    to_width.resize(bgr, resized, {sharpness_width, std::max(1, cvRound(bgr.rows * f))});
    work = resized;
  } else {
    work = bgr;  // never written: `resized` is the only buffer resizes write into
  }
  to_size.resize(work, small, {size, size});
  cv::cvtColor(small, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(work, work_grey, cv::COLOR_BGR2GRAY);
}

}  // namespace keyfleet::agent
