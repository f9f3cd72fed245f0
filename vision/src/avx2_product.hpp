#pragma once
// The matrix product under keyfleet's convolution stand-ins, AVX2 + FMA (x86-64); internal to
// keyfleet_vision. One call computes a block of rows x columns of
//   out[r][n] = (bias ? bias[r] : out[r][n]) + sum over taps t, k < depth of
//               a[t * a_tap_stride + k * rows + r] * b[k * plane + shift[t] + n],
// i.e. a sum of products with the input read in place at a shift per tap (a transposed
// convolution's phase, or a 1x1 convolution with one tap at shift 0), with its 12
// accumulators in registers.
#include <cstddef>
#include <cstdint>
#include <initializer_list>

namespace keyfleet::vision {

bool product_supported();  // x86-64 with AVX2 and FMA

struct ProductBlock {
  int rows;     // output rows per block
  int columns;  // columns per block
  // Of `shapes`, the one that pads `rows` x `columns` the least (ties: the first).
  static ProductBlock least_padding(int rows, int columns,
                                    std::initializer_list<ProductBlock> shapes);
};

// The float kernel's block for `rows` x `columns`: 6 x 16, 4 x 24 or 2 x 48 (12 accumulators of
// 8 floats), the least padding (ties: more rows, fewer loads per product).
ProductBlock float_product_block(int rows, int columns);

// taps: 1, 2, 4 or 9; shifts[taps]. Reads columns [0, block.columns) of b at each shift.
// `stream`: the block's rows are written past the caches (non-temporal stores, where `out` and
// `out_stride` keep its vectors 32-byte aligned; plain stores elsewhere): for a large output that
// nothing reads back before the next layer, whose lines need not be read in first. The thread
// that streamed calls stores_fence() before another reads them.
void product_block(ProductBlock block, int taps, const float* a, std::size_t a_tap_stride,
                   const float* b, const int* shifts, int depth, std::size_t plane,
                   const float* bias, float* out, std::size_t out_stride, bool stream = false);

// Orders this thread's streamed stores before its later ones (x86's sfence; nothing elsewhere).
void stores_fence();

// Outputs of at least this many bytes are written past the caches where nothing reads them back
// within the layer (product_block's `stream`, stream_floats): smaller ones stay in cache for the
// next layer.
constexpr std::size_t kStreamedOutputBytes = std::size_t(4) << 20;

// Whether p keeps 32-byte vectors aligned, as non-temporal stores need.
inline bool vector_aligned(const void* p) {
  return (reinterpret_cast<std::uintptr_t>(p) & 31) == 0;
}

// n floats from src to dst past the caches (non-temporal stores; dst 32-byte aligned), the last
// n % 8 plainly; a plain copy without AVX2. stores_fence() before another thread reads them.
void stream_floats(const float* src, float* dst, int n);

}  // namespace keyfleet::vision
