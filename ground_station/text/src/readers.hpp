#pragma once
// The engines behind make_text_reader.
#include <map>
#include <memory>
#include <optional>
#include <utility>

#include "keyfleet/station/text/lexicon.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "keyfleet/vision/text_segmenter.hpp"
#include "ppocr_detector.hpp"
#include "ppocr_recognizer.hpp"
#include "tesseract_ocr.hpp"

namespace keyfleet::station {

// Tesseract on the whole image: sparse-text page segmentation, word iterator.
class TesseractReader final : public TextReader {
 public:
  explicit TesseractReader(const TextReadingConfig& params);
  std::vector<ReadWord> read(const cv::Mat& bgr) override;
  std::string name() const override { return "tesseract"; }

 private:
  TextReadingConfig params_;
  TesseractOcr ocr_;
};

// MiniNet marks text pixels at one or more input widths (a small pyramid: the network finds
// text of a limited range of heights); connected components of each mask, joined along lines,
// padded and merged across widths, are read one by one by Tesseract as single lines.
class DetectRecogniseReader final : public TextReader {
 public:
  explicit DetectRecogniseReader(const TextReadingConfig& params);
  std::vector<ReadWord> read(const cv::Mat& bgr) override;
  std::string name() const override { return "mininet+tesseract"; }

  // Candidate text boxes in the image's pixels (exposed for evaluation and tests).
  std::vector<cv::Rect> regions(const cv::Mat& bgr);

 private:
  vision::DnnTextSegmenter& segmenter_for(int width, cv::Size image_size);
  std::vector<cv::Rect> regions_at(int width, const cv::Mat& bgr);

  TextReadingConfig params_;
  std::string model_path_;
  TesseractOcr ocr_;
  // The network takes any size that is a multiple of 64; one instance per input size.
  std::map<std::pair<int, int>, std::unique_ptr<vision::DnnTextSegmenter>> segmenters_;
};

// A PP-OCRv4 detector and the largest image "auto" gives it: its own input, or a keyframe's
// 640x480 for a keyframe detector tuned to a smaller input (ppocr_keyframe_detector).
struct SizedPpocrDetector {
  PpocrDetector detector;
  cv::Size holds;
};

// PP-OCRv4: the DB detector finds text lines (at most `max_regions`, the largest), the SVTR
// recogniser reads each, words are split at spaces. With ppocr_detector_size "auto" the
// detector is the one that holds the image (a 640x480 keyframe: the fetched 640x480 file or
// ppocr_keyframe_detector; a 1280x720 photo: 1280x736). Images smaller than a keyframe (word
// crops) are read as one line without detection, as TesseractReader does.
class PpocrReader final : public TextReader {
 public:
  // Throws StartupError naming the first converted file that is missing or unusable.
  explicit PpocrReader(const TextReadingConfig& params);
  std::vector<ReadWord> read(const cv::Mat& bgr) override;
  std::string name() const override { return "ppocr"; }
  // As `region_hints` says (text_reading_config.hpp; ppocr_region_hints.cpp).
  std::vector<ReadWord> read_with_hints(const cv::Mat& bgr,
                                        const std::vector<cv::Rect>& hints) override;

 private:
  // The smallest detector that holds `image`, else the largest.
  PpocrDetector& detector_for(cv::Size image);
  // Recognises each line (the largest `max_regions`) and keeps the words keep_word() accepts:
  // the half of read() that read_with_hints() shares.
  std::vector<ReadWord> read_lines(const cv::Mat& image, std::vector<TextQuad> lines);

  TextReadingConfig params_;
  std::vector<SizedPpocrDetector> detectors_;  // by the area they hold, smallest first
  PpocrRecognizer recognizer_;
  std::unique_ptr<PpocrDetector> hint_detector_;  // region_hints other than "off"
};

// Any engine's words checked against a word list (apply_lexicon): corrected, or dropped.
class LexiconReader final : public TextReader {
 public:
  LexiconReader(std::unique_ptr<TextReader> engine, const std::string& lexicon_path);
  std::vector<ReadWord> read(const cv::Mat& bgr) override;
  std::vector<ReadWord> read_with_hints(const cv::Mat& bgr,
                                        const std::vector<cv::Rect>& hints) override;
  std::string name() const override { return engine_->name() + "+lexicon"; }

 private:
  std::vector<ReadWord> listed(std::vector<ReadWord> read) const;  // corrected or dropped

  std::unique_ptr<TextReader> engine_;
  Lexicon lexicon_;
};

namespace ppocr {

// Where a hinted region of the image lies in a mosaic.
struct MosaicPlacement {
  cv::Rect source;  // in the image
  cv::Point at;     // its top-left corner in the mosaic
};

// The hinted regions of an image padded by `padding` x their height a side (at least 4 px),
// clipped to the image, overlapping ones united, packed in rows (tallest first, `gap` px apart)
// into as many mosaics of `mosaic` size as they need. Empty when a padded region does not fit
// in one mosaic, or when more than `max_mosaics` would be needed.
std::vector<std::vector<MosaicPlacement>> pack_hints(const std::vector<cv::Rect>& hints,
                                                     cv::Size image_size, double padding,
                                                     cv::Size mosaic, int gap,
                                                     std::size_t max_mosaics);

// A line found in a mosaic, moved back into the image; nullopt when its centre lies in no
// placed region (the gaps between them).
std::optional<TextQuad> quad_in_image(const TextQuad& in_mosaic,
                                      const std::vector<MosaicPlacement>& placements);

}  // namespace ppocr

}  // namespace keyfleet::station
