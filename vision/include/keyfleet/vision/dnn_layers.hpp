#pragma once
// Faster stand-ins for OpenCV 4.6 DNN layers, computing the same functions to float rounding:
// - SELU: OpenCV computes it one element at a time with std::exp (about 10 ns an element here, a
//   quarter of MiniNet's forward pass on one thread); this one takes about 0.4 ns (AVX2 where the
//   CPU has it, else cv::hal::exp32f, about 1 ns). It derives from ActivationLayer, so OpenCV
//   still fuses it into the layer before when that layer takes an activation.
// - stride-1 depthwise convolution: OpenCV's costs about a microsecond a channel on the narrow
//   planes of MiniNet's inner layers (16, 8 and 4 columns at 512x256) and more when dilated; this
//   one runs along the rows with SIMD and skips zero taps.
// - transposed 3x3 convolution, stride 2, padding 1, output padding 1 (MiniNet's upsampling), and
//   transposed 2x2 convolution, stride 2, no padding (PP-OCR's DB head): OpenCV multiplies by all
//   taps into a column buffer, then scatters and sums it (col2im); this one computes each of the
//   four output phases as one matrix product over the input read in place (no zero taps, no
//   scatter).
// - 1x1 convolution (stride 1, one group): the same matrix product, the activations after it
//   applied while the columns are in cache.
// - dense 3x3 convolution (stride 1, padding 1, one group): the same matrix product with nine
//   taps over a bordered copy of the input.
// - hard swish, x * min(max(x + 3, 0), 6) / 6 (PP-OCR's activation, one ONNX HardSwish node
//   after models/ppocr/convert_ppocr.py): OpenCV 4.6's HardSwish layer is slower than the five
//   nodes it replaces; this one is SIMD and, as an ActivationLayer, fused into the layer before.
// - power, (shift + scale x)^power (what OpenCV's importer makes of PP-OCR's multiplications and
//   additions by a constant, the learnable affine blocks after each activation): OpenCV 4.6
//   computes it one element at a time; this one in SIMD where power is 1.
// - nearest-neighbour Resize by powers of two (PP-OCR's FPN upsamplings): OpenCV 4.6 computes
//   each element's source with a float product and a conversion; this one widens each input row
//   once and copies it. Where a float 3x3 convolution alone reads a concatenation it writes a
//   slice of (PP-OCR's DB head), an upsampling by 4 or more leaves the slice unwritten and the
//   convolution computes that share at the small size (upsampled_taps).
// - channel scaling x * s by a computed tensor of one float per channel (PP-OCR's squeeze-and-
//   excitation gates): OpenCV's own layer, except where x is a 1x1 convolution's output that only
//   stand-ins read (excited_sums): there the sum after it computes the scaled convolution.
// - inner product with constant weights (PP-OCR's recogniser's last MatMul) as the same matrix
//   product, and softmax over the last axis with OpenCV's vectorised exp (dense_layers.hpp).
// Each stand-in convolution takes the whole chain of activations OpenCV fuses into it (PP-OCR's
// hard swish, scale and shift) and applies it to each output plane while it is in cache. Where a
// depthwise convolution alone reads a float 1x1 or stride-2 first layer's output of 2 MB or more,
// or a narrow 2x2 transposed convolution a wide one's (PP-OCR's DB head), the first stand-in takes
// the second over and runs both a band of rows at a time (banded_depthwise.hpp), where the second
// runs right after the first in a network the scope watches (DnnLayersScope::watch).
// The three product stand-ins need x86-64 with AVX2 and FMA (elsewhere OpenCV's layers stay); any
// other convolution or transposed convolution stays OpenCV's. With `bfloat16_products`, where the
// CPU also has AVX512-BF16, they multiply in bfloat16 with float sums (twice the multiply-adds per
// cycle; inputs and weights rounded to 8 bits of mantissa, so outputs move by about 1 % of their
// spread, not by float rounding); layers with fewer than 8 outputs stay in float.
#include <opencv2/dnn.hpp>

#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace keyfleet::vision {

// Which stand-ins a network gets (DnnTextSegmenter's default: all).
struct DnnLayers {
  bool vectorised_selu = true;
  bool depthwise = true;
  bool subpixel_deconvolution = true;
  bool pointwise = true;
  bool bfloat16_products = true;  // the product stand-ins in bfloat16 where the CPU has it
  bool dense_3x3 = true;
  bool vectorised_hard_swish = true;
  bool vectorised_power = true;
  bool inner_product = true;
  bool vectorised_softmax = true;
  bool global_average_pool = true;  // each plane's mean in SIMD (squeeze-and-excitation blocks)
  bool vectorised_sigmoid = true;   // the logistic function with OpenCV's vectorised exp
  bool nearest_upsampling = true;   // nearest Resize by powers of two: rows widened and copied
  bool vectorised_sum = true;       // Add of inputs of one shape, plane by plane in SIMD
  // The 1x1 convolutions with 64 or more input and output channels in 8-bit integers
  // (pointwise_int8.hpp: weights per output channel, the input over its own range on every
  // call): about 1.8x the multiply-adds per cycle of float on AVX2; outputs move by about 1 % of
  // their spread. Off unless asked for.
  bool int8_pointwise = false;
  // A float 1x1 convolution and the depthwise convolution that alone reads its output, run a band
  // of rows at a time so that output stays in cache (banded_depthwise.hpp): the same sums.
  bool banded_depthwise = true;
  // A float 3x3 convolution that alone reads a concatenation of nearest upsamplings by 4 or more
  // each way (PP-OCR's DB head) computes their share at the small size, the upsampled slices
  // never written (upsampled_taps.hpp): the same sums in another order (float rounding).
  bool upsampled_taps = true;
  // A float 1x1 convolution whose output only a global average pooling and a channel scaling
  // read, the scaling's only an element-wise sum (PP-OCR's RSE layers): the pooling from the
  // convolution's input, the convolution scaled and summed in one pass by the sum, neither
  // output written (pointwise_hand_over.hpp): the same sums to float rounding.
  bool excited_sums = true;
  static DnnLayers opencv() {
    return {false, false, false, false, false, false, false,
            false, false, false, false, false, false, false};
  }
  // All stand-ins in float: OpenCV's outputs to float rounding, on any CPU.
  static DnnLayers in_float() {
    return {true, true, true, true, false, true, true, true, true, true, true, true, true, true};
  }
  bool any() const {
    return vectorised_selu || depthwise || subpixel_deconvolution || pointwise || dense_3x3 ||
           vectorised_hard_swish || vectorised_power || inner_product || vectorised_softmax ||
           global_average_pool || vectorised_sigmoid || nearest_upsampling || vectorised_sum;
  }
};

// Whether this CPU runs the transposed and 1x1 convolution stand-ins (x86-64 with AVX2 and FMA),
// and whether in bfloat16 (AVX512F and AVX512-BF16).
bool matrix_product_layers_supported();
bool bfloat16_products_supported();

// selu(x) = gamma * (max(x, 0) + alpha * (exp(min(x, 0)) - 1)), for n floats (in place allowed).
void selu_vectorised(const float* src, float* dst, int n, float alpha, float gamma);

// hard_swish(x) = x * min(max(x + 3, 0), 6) / 6, for n floats (in place allowed).
void hard_swish_vectorised(const float* src, float* dst, int n);

// While alive, networks whose layers are created (on import and on their first forward pass)
// get the chosen stand-ins for ONNX "Selu", "HardSwish", "Conv" and "ConvTranspose" nodes. OpenCV's
// layer registry is process-wide: keep the scope to the construction of one network (layers already
// created keep their class). One scope at a time in a process: a second one waits for the first to
// end.
class DnnLayersScope {
 public:
  explicit DnnLayersScope(DnnLayers layers);
  ~DnnLayersScope();
  DnnLayersScope(const DnnLayersScope&) = delete;
  DnnLayersScope& operator=(const DnnLayersScope&) = delete;

  // The network (or one of the networks) whose layers this scope creates, named before its first
  // forward pass (load_onnx_network() names the networks it loads to the calling thread's scope).
  // A stand-in takes over the layer that reads its output (banded_depthwise, the DB head's pair)
  // only where that layer runs right after it in OpenCV's order, nothing of another branch
  // between them (whose blobs OpenCV may lay over the output the pair writes early): it reads the
  // order off this network when OpenCV first fuses, and keeps what it decided for later set-ups.
  // The layers of a network never named here take nothing over.
  void watch(const cv::dnn::Net& net);
  const std::vector<cv::dnn::Net>& watched() const { return watched_; }
  // The calling thread's scope, or null.
  static DnnLayersScope* current();
  // For the stand-ins: every layer that reads `layer`'s outputs in the watched network holding it
  // (a layer reading it twice is there twice); false where no watched network holds it. Indexed
  // once a network (the networks are whole by their first set-up).
  bool readers(const cv::dnn::Layer& layer, std::vector<cv::Ptr<cv::dnn::Layer>>& found);

 private:
  static std::mutex& scope_mutex();  // OpenCV refuses a second registration of a constructor
  void unregister();

  std::unique_lock<std::mutex> lock_;
  std::vector<std::string> registered_;
  std::vector<cv::dnn::Net> watched_;
  // Per watched network (by its index): each layer's readers.
  std::vector<std::map<const cv::dnn::Layer*, std::vector<cv::Ptr<cv::dnn::Layer>>>> readers_;
};

}  // namespace keyfleet::vision
