#include "keyfleet/eval/seed_aggregate.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <sstream>
#include <utility>

#include "keyfleet/common/file_output.hpp"

namespace keyfleet::eval {
namespace {

namespace fs = std::filesystem;

nlohmann::json interval_json(const Interval& i) {
  return {{"n", i.n}, {"mean", i.mean}, {"low", i.low}, {"high", i.high}};
}

std::string interval_text(const Interval& i, double scale, int decimals) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(decimals);
  out << i.mean * scale << " [" << i.low * scale << ", " << i.high * scale << "]";
  return out.str();
}

}  // namespace

double student_t_975(std::size_t degrees) {
  // Two-sided 95 % critical values of Student's t, degrees of freedom 1..30.
  static const double kTable[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306,
                                  2.262,  2.228, 2.201, 2.179, 2.160, 2.145, 2.131, 2.120,
                                  2.110,  2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
                                  2.060,  2.056, 2.052, 2.048, 2.045, 2.042};
  if (degrees == 0) return 0;
  if (degrees <= 30) return kTable[degrees - 1];
  if (degrees <= 60) return 2.000;
  if (degrees <= 120) return 1.980;
  return 1.960;
}

Interval mean_interval(const std::vector<double>& samples) {
  Interval out;
  out.n = samples.size();
  if (samples.empty()) return out;
  double sum = 0;
  for (double s : samples) sum += s;
  out.mean = sum / double(out.n);
  out.low = out.high = out.mean;
  if (out.n < 2) return out;
  double squares = 0;
  for (double s : samples) squares += (s - out.mean) * (s - out.mean);
  const double sd = std::sqrt(squares / double(out.n - 1));
  const double half = student_t_975(out.n - 1) * sd / std::sqrt(double(out.n));
  out.low = out.mean - half;
  out.high = out.mean + half;
  return out;
}

std::vector<SeedPoint> aggregate_seeds(const std::vector<EvalResults>& runs) {
  std::vector<SeedPoint> points;
  if (runs.empty()) return points;
  for (const auto& first : runs.front().summary) {
    std::vector<double> read, full, in_sequence, recall, top1, top5, keyframes;
    std::vector<double> read_vs_vslam, top1_vs_vslam;
    for (const auto& run : runs) {
      const PointSummary* p = find_point(run.summary, first.strategy, first.density);
      if (!p) continue;
      if (const PointSummary* vslam = find_point(run.summary, "vslam", first.density)) {
        read_vs_vslam.push_back(double(p->words_read) - double(vslam->words_read));
        top1_vs_vslam.push_back(p->topk.top1_rate() - vslam->topk.top1_rate());
      }
      read.push_back(double(p->words_read));
      full.push_back(double(p->full_words));
      in_sequence.push_back(double(p->words_in_sequence));
      recall.push_back(p->word_recall);
      top1.push_back(p->topk.top1_rate());
      top5.push_back(p->topk.top5_rate());
      keyframes.push_back(double(p->keyframes));
    }
    SeedPoint point;
    point.strategy = first.strategy;
    point.density = first.density;
    point.words_read = mean_interval(read);
    point.full_words = mean_interval(full);
    point.words_in_sequence = mean_interval(in_sequence);
    point.word_recall = mean_interval(recall);
    point.top1 = mean_interval(top1);
    point.top5 = mean_interval(top5);
    point.keyframes = mean_interval(keyframes);
    point.words_read_vs_vslam = mean_interval(read_vs_vslam);
    point.top1_vs_vslam = mean_interval(top1_vs_vslam);
    points.push_back(std::move(point));
  }
  return points;
}

void write_seed_results(const std::vector<SeedPoint>& points,
                        const std::vector<std::uint64_t>& seeds, const std::string& out_dir) {
  const fs::path dir(out_dir);
  nlohmann::json doc;
  doc["seeds"] = seeds;
  doc["interval"] = "95 % Student t interval of the mean over the seeds";
  doc["points"] = nlohmann::json::array();
  std::ostringstream csv, md;
  csv << "strategy,density,n,words_read_mean,words_read_low,words_read_high,full_words_mean,"
         "full_words_low,full_words_high,top1_mean,top1_low,top1_high,top5_mean,top5_low,"
         "top5_high\n";
  md << "# keyfleet eval over " << seeds.size() << " seeds\n\n"
     << "Mean [95 % interval] over the seeds of distinct signs read, signs fully visible in the "
        "selected keyframes, and place recognition top-1 / top-5 (%).\n\n"
     << "| strategy | kept | keyframes | words read | words fully visible | top-1 % | top-5 % "
        "| words read - vslam | top-1 - vslam (points) |\n"
     << "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& p : points) {
    doc["points"].push_back({{"strategy", p.strategy},
                             {"density", p.density},
                             {"keyframes", interval_json(p.keyframes)},
                             {"words_read", interval_json(p.words_read)},
                             {"full_words", interval_json(p.full_words)},
                             {"words_in_sequence", interval_json(p.words_in_sequence)},
                             {"word_recall", interval_json(p.word_recall)},
                             {"top1", interval_json(p.top1)},
                             {"top5", interval_json(p.top5)},
                             {"words_read_vs_vslam", interval_json(p.words_read_vs_vslam)},
                             {"top1_vs_vslam", interval_json(p.top1_vs_vslam)}});
    csv << p.strategy << "," << p.density << "," << p.words_read.n;
    for (const Interval* i : {&p.words_read, &p.full_words, &p.top1, &p.top5})
      csv << "," << i->mean << "," << i->low << "," << i->high;
    csv << "\n";
    md << "| " << p.strategy << " | " << p.density * 100 << " % | "
       << interval_text(p.keyframes, 1, 1) << " | " << interval_text(p.words_read, 1, 1) << " | "
       << interval_text(p.full_words, 1, 1) << " | " << interval_text(p.top1, 100, 1) << " | "
       << interval_text(p.top5, 100, 1) << " | " << interval_text(p.words_read_vs_vslam, 1, 1)
       << " | " << interval_text(p.top1_vs_vslam, 100, 1) << " |\n";
  }
  write_file(dir / "seeds.json", doc.dump(2) + "\n");
  write_file(dir / "seeds.csv", csv.str());
  write_file(dir / "seeds.md", md.str());
}

}  // namespace keyfleet::eval
