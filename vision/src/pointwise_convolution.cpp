#include "pointwise_convolution.hpp"

#include <algorithm>
#include <vector>

namespace keyfleet::vision {

void PointwiseConvolution::pack(ProductBlock block) {
  block_ = block;
  row_blocks_ = (cout_ + block_.rows - 1) / block_.rows;
  const float* w = weights_.ptr<float>();  // [cout][cin]
  packed_.pack(block, 1, cin_, cout_, bfloat16_,
               [&](int co, int ci, int) { return w[std::size_t(co) * cin_ + ci]; });
}

namespace {

// Float blocks whose rows divide the outputs, where one does (the columns' remainder then runs
// as one padded tail block): no padded copy of the input and no products buffer.
ProductBlock whole_rows_block(int outputs, int pixels) {
  for (const ProductBlock shape : {ProductBlock{6, 16}, ProductBlock{4, 24}, ProductBlock{2, 48}})
    if (outputs % shape.rows == 0) return shape;
  return float_product_block(outputs, pixels);
}

}  // namespace

void PointwiseConvolution::run(const float* src, int pixels, float* dst,
                               const cv::dnn::ActivationLayer* activation) {
  const ProductBlock block =
      bfloat16_ ? bf16_product_block(cout_, pixels) : whole_rows_block(cout_, pixels);
  if (block.rows != block_.rows) pack(block);
  if (!bfloat16_ && cout_ % block_.rows == 0) {
    run_in_place(src, std::size_t(pixels), pixels, dst, std::size_t(pixels), activation);
    return;
  }
  const int width = block_.columns;
  const int columns = (pixels + width - 1) / width * width;
  // The input in place when its planes are whole blocks, else copied with zero columns after;
  // in bfloat16, converted to pairs with zero columns after.
  if (bfloat16_ || columns != pixels)
    input_.fill(src, cin_, 1, pixels, bfloat16_, columns, pixels);
  else
    input_.use(src, columns);
  // The products straight into dst when they fill it exactly, else into a buffer first.
  const bool direct = columns == pixels && cout_ % block_.rows == 0;
  float* out = dst;
  if (!direct) {
    products_.resize(std::size_t(row_blocks_) * block_.rows * columns);
    out = products_.data();
  }
  // Input channels in chunks whose block columns stay within about 16 KB (L1); stripes of a
  // few blocks, finished (activation included) before the next.
  const int total = summed(), depth = summed_chunk(total, 1, width);
  constexpr int kStripe = 4;
  const int stripes = (columns / width + kStripe - 1) / kStripe;
  const int zero_shift = 0;
  cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& range) {
    for (int stripe = range.start; stripe < range.end; ++stripe) {
      const int first = stripe * kStripe, last = std::min(columns / width, first + kStripe);
      for (int k0 = 0; k0 < total; k0 += depth) {
        const int k = std::min(depth, total - k0);
        for (int blk = first; blk < last; ++blk)
          for (int rb = 0; rb < row_blocks_; ++rb) {
            const std::size_t a = (std::size_t(rb) * total + k0) * block_.rows;
            const float* bias = k0 == 0 ? bias_.data() + rb * block_.rows : nullptr;
            float* o = out + std::size_t(rb) * block_.rows * columns + blk * width;
            input_.multiply(block_, 1, packed_, a, 0, k0, blk * width, &zero_shift, k, bias, o,
                            columns);
          }
      }
      finish_columns(direct ? nullptr : out, columns, cout_, first * width,
                     std::min(pixels, last * width), dst, pixels, activation);
    }
  });
}

void PointwiseConvolution::run_columns(const float* src, std::size_t src_plane, int pixels,
                                       float* dst, std::size_t dst_plane,
                                       const cv::dnn::ActivationLayer* activation) {
  pack_for_columns(pixels);
  run_in_place(src, src_plane, pixels, dst, dst_plane, activation);
}

void PointwiseConvolution::run_columns(const float* src, std::size_t src_plane, int pixels,
                                       float* dst, std::size_t dst_plane,
                                       const ColumnsEpilogue& epilogue) {
  pack_for_columns(pixels);
  run_in_place(src, src_plane, pixels, dst, dst_plane, nullptr, &epilogue);
}

void PointwiseConvolution::pack_for_columns(int pixels) {
  CV_Assert(runs_columns());
  const ProductBlock block = whole_rows_block(cout_, pixels);
  if (block.rows != block_.rows) pack(block);
  CV_Assert(cout_ % block_.rows == 0);
}

void PointwiseConvolution::run_in_place(const float* src, std::size_t src_plane, int pixels,
                                        float* dst, std::size_t dst_plane,
                                        const cv::dnn::ActivationLayer* activation,
                                        const ColumnsEpilogue* epilogue) {
  CV_Assert(!(activation && epilogue));
  // Whole blocks read src and write dst where they are (planes `src_plane` and `dst_plane`
  // apart); the columns' remainder, if any, is one block of its own, copied with zero columns after
  // and multiplied into a small buffer, then copied into dst. Padding the whole input and the
  // products instead took twice as long on a 16 -> 32 layer of 160 x 128 (the first 1x1 layer of
  // PP-OCR's detector at 320x256).
  const int width = block_.columns;
  const int whole = pixels / width, tail = pixels - whole * width;
  const int blocks = whole + (tail ? 1 : 0);
  input_.use(src, src_plane);
  if (tail) {
    tail_input_buffer_.assign(std::size_t(cin_) * width, 0.f);
    for (int c = 0; c < cin_; ++c)
      std::copy_n(src + c * src_plane + whole * width, tail,
                  tail_input_buffer_.data() + std::size_t(c) * width);
    tail_input_.use(tail_input_buffer_.data(), width);
    products_.resize(std::size_t(cout_) * width);
  }
  const int total = summed(), depth = summed_chunk(total, 1, width);
  // A large output that nothing reads back here (no activation to apply, the input channels
  // summed in one chunk) is written past the caches: most of the time of a layer with few inputs
  // and many outputs (PP-OCR's neck, 12 -> 96 channels, 7.4 MB at 640x480) went to reading in
  // the lines its first stores missed, as many streams as outputs.
  const bool large = depth >= total && !bfloat16_ &&
                     std::size_t(cout_) * dst_plane * sizeof(float) >= kStreamedOutputBytes;
  const bool finished = activation || epilogue;  // something to do to each stripe
  const bool stream = large && !finished;
  // With an activation (or an epilogue), a stripe's whole blocks are multiplied and activated in a
  // buffer that stays in L1, then streamed to dst (where its planes keep the vectors 32-byte
  // aligned).
  constexpr int kStripe = 4;
  const std::size_t buffer_stride = std::size_t(kStripe) * width;
  const bool stream_finished = large && finished && dst_plane % 8 == 0 && vector_aligned(dst);
  const int stripes = (blocks + kStripe - 1) / kStripe;
  const int zero_shift = 0;
  cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& range) {
    thread_local std::vector<float> stripe_buffer;
    if (stream_finished) stripe_buffer.resize(std::size_t(cout_) * buffer_stride);
    for (int stripe = range.start; stripe < range.end; ++stripe) {
      const int first = stripe * kStripe, last = std::min(blocks, first + kStripe);
      for (int k0 = 0; k0 < total; k0 += depth) {
        const int k = std::min(depth, total - k0);
        for (int blk = first; blk < last; ++blk) {
          const bool is_tail = blk == whole;
          const ProductInput& in = is_tail ? tail_input_ : input_;
          const int n0 = is_tail ? 0 : blk * width;
          std::size_t stride = dst_plane;
          float* base = dst + n0;
          if (is_tail) {
            stride = width;
            base = products_.data();
          } else if (stream_finished) {
            stride = buffer_stride;
            base = stripe_buffer.data() + (blk - first) * width;
          }
          for (int rb = 0; rb < row_blocks_; ++rb) {
            const std::size_t a = (std::size_t(rb) * total + k0) * block_.rows;
            const float* bias = k0 == 0 ? bias_.data() + rb * block_.rows : nullptr;
            in.multiply(block_, 1, packed_, a, 0, k0, n0, &zero_shift, k, bias,
                        base + std::size_t(rb) * block_.rows * stride, stride, stream && !is_tail);
          }
        }
      }
      const int whole_last = std::min(last, whole);  // this stripe's whole blocks end here
      if (stream_finished && whole_last > first) {
        const int n = (whole_last - first) * width;
        if (epilogue)
          epilogue->apply(stripe_buffer.data(), buffer_stride, first * width, n);
        else
          activation->forwardSlice(stripe_buffer.data(), stripe_buffer.data(), n, buffer_stride, 0,
                                   cout_);
        for (int c = 0; c < cout_; ++c)
          stream_floats(stripe_buffer.data() + c * buffer_stride,
                        dst + c * dst_plane + first * width, n);
      }
      if (last == blocks && tail)
        for (int c = 0; c < cout_; ++c)
          std::copy_n(products_.data() + std::size_t(c) * width, tail,
                      dst + c * dst_plane + whole * width);
      const int n0 = (stream_finished ? whole_last : first) * width;
      const int n1 = std::min(pixels, last * width);
      if (epilogue && n1 > n0)
        epilogue->apply(dst + n0, dst_plane, n0, n1 - n0);
      else
        finish_columns(nullptr, pixels, cout_, n0, n1, dst, int(dst_plane), activation);
    }
    if (stream || stream_finished) stores_fence();  // the streamed lines visible before the end
  });
}

}  // namespace keyfleet::vision
