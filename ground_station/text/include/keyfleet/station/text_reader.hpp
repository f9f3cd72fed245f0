#pragma once
// The text-reading seam of the ground station: words (text, confidence, box) read from a
// keyframe. Real engines use Tesseract 5; tests may substitute their own reader.
#include <opencv2/core.hpp>

#include <memory>
#include <string>
#include <vector>

namespace keyfleet::station {

struct ReadWord {
  std::string text;      // UTF-8
  float confidence = 0;  // 0..1
  cv::Rect box;          // in the input image's pixels
};

class TextReader {
 public:
  virtual ~TextReader() = default;
  // Never throws on a bad image (empty, tiny, wrong type): returns no words.
  virtual std::vector<ReadWord> read(const cv::Mat& bgr) = 0;
  virtual std::string name() const = 0;
};

struct TextReaderParams {
  // "tesseract": Tesseract on the whole image (sparse text); "mininet+tesseract": MiniNet
  // finds text regions, Tesseract reads each as one line. The default won on the measured
  // end-to-end F (`keyfleet ocr eval`: 32 vs 9 % on ICDAR 2015 train_sharp).
  std::string engine = "tesseract";
  std::string tessdata_dir;  // empty = Debian's /usr/share/tesseract-ocr/5/tessdata
  std::string language = "eng";
  // Tesseract's binarisation: 0 global Otsu, 1 tiled Otsu (Leptonica), 2 Sauvola. Scene
  // photos mix light-on-dark and dark-on-light signs, which one global threshold loses.
  int thresholding_method = 1;
  float min_confidence = 0.7f;  // 0..1; words below are dropped
  int min_word_length = 2;      // characters (UTF-8 code points); shorter words are dropped
  int min_word_height = 8;      // pixels in the input image; smaller "words" are noise
  // Images whose longer side is below this are upscaled to it before reading (pixels).
  // Measured on ICDAR 2015: upscaling 1280x720 photos further loses words.
  int min_long_side = 1280;
  // Images whose longer side is above this are downscaled to it (pixels, 0 = never).
  int max_long_side = 0;
  // Detector (mininet+tesseract): the segmenter model and the input widths it runs at (pixels,
  // multiples of 64; height keeps the image's aspect ratio), regions merged over the widths.
  // The shipped MiniNet sees text of a limited range of heights: on ICDAR train_sharp
  // (1280x720) one width gave F 0 % at 512, 28.6 % at 768, 7.1 % at 1024; 512 finds the
  // large words of a 640x480 keyframe that 768 misses.
  std::string segmenter_model = "mininet_text.onnx";
  std::vector<int> segmenter_widths = {512, 768};
  int threads = 1;              // OpenCV DNN threads for the segmenter
  float region_padding = 0.3f;  // each side, as a fraction of the region's height
  int region_line_height = 48;  // pixels a region's crop is scaled to before reading
  int max_regions = 40;         // largest regions read per image (bounds the cost)
};

// Throws StartupError on an unknown engine, missing/unreadable traineddata or a bad model.
std::unique_ptr<TextReader> make_text_reader(const TextReaderParams& params);

// The engine names make_text_reader accepts.
std::vector<std::string> text_reader_engines();

// The junk filter shared by the engines: at least `min_word_length` characters and
// `min_word_height` pixels, confidence at least `min_confidence`, half or more letters/digits.
bool keep_word(const ReadWord& word, const TextReaderParams& params);

}  // namespace keyfleet::station
