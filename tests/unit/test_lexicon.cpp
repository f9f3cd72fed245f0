// The word list the station's readings are checked against: nearest word, case, what passes.
#include <gtest/gtest.h>

#include <fstream>

#include "keyfleet/common/error.hpp"
#include "keyfleet/station/text/lexicon.hpp"
#include "keyfleet/station/text/text_reader.hpp"
#include "test_support.hpp"

namespace keyfleet::station {
namespace {

TEST(Lexicon, KnownWordsAndNearestWithinTheEditLimit) {
  const Lexicon lexicon(std::vector<std::string>{"Shops", "shop", "passenger", "Theatre", "exit"});
  EXPECT_EQ(lexicon.size(), 5u);
  EXPECT_EQ(lexicon.nearest("THEATRE"), "theatre");
  EXPECT_EQ(lexicon.nearest("Shopa"), "shops");  // substitution preferred to "shop" (deletion)
  EXPECT_EQ(lexicon.nearest("Pasenger"), "passenger");
  EXPECT_EQ(lexicon.nearest("EXlT"), std::nullopt);     // 4 letters: exact only
  EXPECT_EQ(lexicon.nearest("Thxxtre"), std::nullopt);  // 2 edits on 7 letters
  EXPECT_EQ(Lexicon::max_edits(4), 0);
  EXPECT_EQ(Lexicon::max_edits(8), 1);
  EXPECT_EQ(Lexicon::max_edits(9), 2);
}

TEST(Lexicon, ApplyKeepsCaseAndPunctuationPassesNumbersDropsStrangers) {
  const Lexicon lexicon(std::vector<std::string>{"shops", "minute", "Dine"});
  EXPECT_EQ(apply_lexicon(lexicon, "SHOPA"), "SHOPS");
  EXPECT_EQ(apply_lexicon(lexicon, "Shopa"), "Shops");
  EXPECT_EQ(apply_lexicon(lexicon, "minute;"), "minute;");
  EXPECT_EQ(apply_lexicon(lexicon, "\"Dlne\""), std::nullopt);  // 4 letters, not listed
  EXPECT_EQ(apply_lexicon(lexicon, "62-03"), "62-03");
  EXPECT_EQ(apply_lexicon(lexicon, "$4.00"), "$4.00");
  EXPECT_EQ(apply_lexicon(lexicon, "B2"), "B2");
  EXPECT_EQ(apply_lexicon(lexicon, "xqzvw"), std::nullopt);
}

TEST(Lexicon, FileErrorsAreStartupErrors) {
  test::TempDir dir;
  EXPECT_THROW(Lexicon(dir.file("missing.txt")), StartupError);
  {
    std::ofstream out(dir.file("empty.txt"));
    out << "\n  \n";
  }
  EXPECT_THROW(Lexicon(dir.file("empty.txt")), StartupError);
  {
    std::ofstream out(dir.file("words.txt"));
    out << "hotel\r\n taxi \n";
  }
  EXPECT_EQ(Lexicon(dir.file("words.txt")).nearest("TAXI"), "taxi");
  TextReadingConfig config;
  config.engine = "tesseract";
  config.lexicon = dir.file("missing.txt");
  EXPECT_THROW(make_text_reader(config), StartupError);
  config.lexicon = dir.file("words.txt");
  EXPECT_EQ(make_text_reader(config)->name(), "tesseract+lexicon");
}

}  // namespace
}  // namespace keyfleet::station
