#pragma once
// The matrix product of avx2_product.hpp with bfloat16 operands and float sums (AVX512-BF16's
// dot product: twice the multiply-adds per cycle of float FMA on the CPUs that have it). The
// summed dimension comes in pairs: a uint32 holds index 2p in its low half and 2p + 1 in its high
// half, each rounded to the nearest bfloat16 (8 bits of mantissa). One call computes a block of
// rows x columns of
//   out[r][n] = (bias ? bias[r] : out[r][n]) + sum over taps t, pairs p < pairs of
//               a[t * a_tap_stride + p * rows + r] . b[p * plane + shift[t] + n]
// where . is the two-term dot product of a pair. Internal to keyfleet_vision.
#include <cstddef>
#include <cstdint>

#include "avx2_product.hpp"

namespace keyfleet::vision {

bool bf16_product_supported();  // x86-64 with AVX512F and AVX512-BF16

// Whether a layer with `outputs` channels should multiply in bfloat16: the CPU has it and there
// are at least 8 outputs (fewer would not repay converting the input to pairs).
bool bf16_product_pays(int outputs);

// The block for `rows` x `columns`: 6 x 64, 8 x 48, 4 x 96 or 12 x 32 (24 accumulators of 16
// floats), the least padding (ties: in that order).
ProductBlock bf16_product_block(int rows, int columns);

// The pair of two floats, each rounded to the nearest bfloat16 (ties to even).
std::uint32_t bf16_pair(float low, float high);

// Channel c of src (planes of rows x width floats, contiguous) goes to half c % 2 of
// dst[(c / 2) * dst_plane + y * dst_row_stride + x]; an odd last channel pairs with zero. Other
// places of dst are left as they are.
void pack_bf16_pairs(const float* src, int channels, int rows, int width, std::uint32_t* dst,
                     std::size_t dst_plane, int dst_row_stride);

// taps: 1, 2, 4 or 9; shifts[taps]. Reads columns [0, block.columns) of b at each shift.
void product_block_bf16(ProductBlock block, int taps, const std::uint32_t* a,
                        std::size_t a_tap_stride, const std::uint32_t* b, const int* shifts,
                        int pairs, std::size_t plane, const float* bias, float* out,
                        std::size_t out_stride);

}  // namespace keyfleet::vision
