#pragma once
// The matrix product of avx2_product.hpp with 8-bit integer operands and 32-bit integer sums
// (AVX2's vpmaddubsw then vpmaddwd: about 1.8x the multiply-adds per cycle of float FMA on one
// core here; VNNI's vpdpbusd where the CPU has it), for layers whose input is quantized as it
// arrives (pointwise_int8.hpp). The summed dimension comes in quads: a uint32 holds four
// consecutive input channels, one byte each (the first in the lowest byte). The input's bytes are
// unsigned and within 0 to 127 (7 bits), the weights' signed and within -127 to 127, so
// vpmaddubsw's 16-bit sums of two products (at most 2 x 127 x 127 = 32258) never saturate and the
// integer sums are exact. (Of the two ways to stay under saturation, 7-bit inputs and 8-bit weights
// read more of PP-OCR's words than 8-bit inputs and 7-bit weights: 223 against 219 of 300 word
// crops, F 50.3 against 49.9 %.) One call computes a block of rows x columns of
//   out[r][n] = scale[r] * (sum over quads q < quads of a[q * rows + r] . b[q * plane + n])
//               + (offset ? offset[r] : out[r][n])
// where . is the four-term dot product of a quad. Internal to keyfleet_vision.
#include <cstddef>
#include <cstdint>

#include "avx2_product.hpp"

namespace keyfleet::vision {

constexpr int kInt8WeightLimit = 127;  // weights' bytes are within +-this
constexpr int kInt8InputLevels = 127;  // the input's bytes are within 0..this

// The block for `rows` x `columns`: 4 x 16 or 2 x 32 (8 accumulators of 8 sums: the products
// need a register each on their way), the least padding (ties: 4 x 16).
ProductBlock int8_product_block(int rows, int columns);

// The smallest and largest of n floats (n > 0).
void float_range(const float* src, std::size_t n, float* lowest, float* highest);

// Channels of src (`channels` planes of `pixels` floats, contiguous) quantized as
// min(max(round(x * inverse_scale) + zero, 0), kInt8InputLevels) into quads: quad q of column n
// goes to dst[q * plane + n]; channels past the last (up to a whole quad) and columns from `pixels`
// to `plane` are `zero`. plane >= pixels.
void quantize_quads(const float* src, int channels, int pixels, float inverse_scale, int zero,
                    std::uint32_t* dst, std::size_t plane);

// The instructions the products run with: "AVX512-VNNI" (where OpenCV may use AVX-512 and the CPU
// has AVX512-VNNI), "AVX-VNNI" (CPUs with it and without AVX-512), else "AVX2"; or the one the
// environment's KEYFLEET_INT8_INSTRUCTIONS (avx2, avx-vnni, avx512-vnni) names, where the CPU has
// it. The sums are the same with each.
const char* int8_instructions();

// Reads columns [0, block.columns) of b.
void product_block_int8(ProductBlock block, const std::uint32_t* a, const std::uint32_t* b,
                        int quads, std::size_t plane, const float* scale, const float* offset,
                        float* out, std::size_t out_stride);

}  // namespace keyfleet::vision
