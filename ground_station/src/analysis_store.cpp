#include "keyfleet/station/analysis_store.hpp"

#include <algorithm>
#include <cstring>
#include <set>

#include "keyfleet/station/station_schema.hpp"

namespace keyfleet::station {
namespace {

// Keypoints as 6 floats each: x, y, size, angle, response, octave.
std::vector<std::uint8_t> pack_keypoints(const std::vector<cv::KeyPoint>& keypoints) {
  std::vector<float> values;
  values.reserve(keypoints.size() * 6);
  for (const cv::KeyPoint& k : keypoints) {
    values.insert(values.end(),
                  {k.pt.x, k.pt.y, k.size, k.angle, k.response, static_cast<float>(k.octave)});
  }
  std::vector<std::uint8_t> bytes(values.size() * sizeof(float));
  if (!bytes.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

std::vector<cv::KeyPoint> unpack_keypoints(const std::vector<std::uint8_t>& bytes) {
  std::vector<float> values(bytes.size() / sizeof(float));
  if (!values.empty()) std::memcpy(values.data(), bytes.data(), values.size() * sizeof(float));
  std::vector<cv::KeyPoint> keypoints;
  keypoints.reserve(values.size() / 6);
  for (std::size_t i = 0; i + 6 <= values.size(); i += 6) {
    keypoints.emplace_back(values[i], values[i + 1], values[i + 2], values[i + 3], values[i + 4],
                           static_cast<int>(values[i + 5]));
  }
  return keypoints;
}

std::vector<std::uint8_t> pack_descriptors(const cv::Mat& descriptors) {
  const cv::Mat dense = descriptors.isContinuous() ? descriptors : descriptors.clone();
  return std::vector<std::uint8_t>(dense.data, dense.data + dense.total() * dense.elemSize());
}

std::int64_t as_int(std::uint64_t v) { return static_cast<std::int64_t>(v); }

}  // namespace

AnalysisStore::AnalysisStore(const std::string& path, SqliteDb::Mode mode) : db_(path, mode) {
  open_station_schema(db_, mode);
}

void AnalysisStore::save(const AnalysisResult& r) {
  db_.exec("BEGIN IMMEDIATE");
  try {
    const std::int64_t seq = as_int(r.key.sequence);
    auto order = db_.prepare("SELECT COALESCE(MAX(analysed_order), 0) + 1 FROM keyframe_analysis");
    order.step();
    db_.prepare(
           "INSERT OR REPLACE INTO keyframe_analysis(robot_id, sequence_number, capture_time_ns, "
           "status, detail, analysed_order, words, candidates_checked, text_ms, places_ms, "
           "text_cpu_ms) VALUES(?,?,?,?,?,?,?,?,?,?,?)")
        .bind(1, r.key.robot_id)
        .bind(2, seq)
        .bind(3, r.capture_time_ns)
        .bind(4, std::string(to_string(r.status)))
        .bind(5, r.detail)
        .bind(6, order.int64(0))
        .bind(7, static_cast<std::int64_t>(r.words.size()))
        .bind(8, static_cast<std::int64_t>(r.candidates_checked))
        .bind(9, r.text_ms)
        .bind(10, r.places_ms)
        .bind(11, r.text_cpu_ms)
        .step();
    if (r.status == AnalysisStatus::kDone) {
      // A keyframe analysed again (after a restart mid-analysis) replaces its old words.
      db_.prepare(
             "INSERT INTO words_fts(words_fts, rowid, text) SELECT 'delete', word_id, text FROM "
             "words WHERE robot_id = ? AND sequence_number = ?")
          .bind(1, r.key.robot_id)
          .bind(2, seq)
          .step();
      db_.prepare("DELETE FROM words WHERE robot_id = ? AND sequence_number = ?")
          .bind(1, r.key.robot_id)
          .bind(2, seq)
          .step();
      for (const ReadWord& w : r.words) {
        db_.prepare(
               "INSERT INTO words(robot_id, sequence_number, text, confidence, x, y, width, "
               "height) VALUES(?,?,?,?,?,?,?,?)")
            .bind(1, r.key.robot_id)
            .bind(2, seq)
            .bind(3, w.text)
            .bind(4, static_cast<double>(w.confidence))
            .bind(5, std::int64_t{w.box.x})
            .bind(6, std::int64_t{w.box.y})
            .bind(7, std::int64_t{w.box.width})
            .bind(8, std::int64_t{w.box.height})
            .step();
        db_.prepare("INSERT INTO words_fts(rowid, text) VALUES(last_insert_rowid(), ?)")
            .bind(1, w.text)
            .step();
      }
      if (r.features) {
        db_.prepare(
               "INSERT OR REPLACE INTO keyframe_features(robot_id, sequence_number, count, "
               "keypoints, descriptors) VALUES(?,?,?,?,?)")
            .bind(1, r.key.robot_id)
            .bind(2, seq)
            .bind(3, static_cast<std::int64_t>(r.features->keypoints.size()))
            .bind(4, pack_keypoints(r.features->keypoints))
            .bind(5, pack_descriptors(r.features->descriptors))
            .step();
      }
      if (!r.descriptor.empty()) {
        std::vector<std::uint8_t> bytes(r.descriptor.size() * sizeof(float));
        std::memcpy(bytes.data(), r.descriptor.data(), bytes.size());
        db_.prepare(
               "INSERT OR REPLACE INTO keyframe_descriptors(robot_id, sequence_number, "
               "dimensions, descriptor) VALUES(?,?,?,?)")
            .bind(1, r.key.robot_id)
            .bind(2, seq)
            .bind(3, static_cast<std::int64_t>(r.descriptor.size()))
            .bind(4, bytes)
            .step();
      }
      if (r.place) {
        db_.prepare(
               "INSERT OR REPLACE INTO place_matches(robot_id, sequence_number, match_robot_id, "
               "match_sequence_number, matches, inliers, bow_score) VALUES(?,?,?,?,?,?,?)")
            .bind(1, r.key.robot_id)
            .bind(2, seq)
            .bind(3, r.place->other.robot_id)
            .bind(4, as_int(r.place->other.sequence))
            .bind(5, static_cast<std::int64_t>(r.place->matches))
            .bind(6, static_cast<std::int64_t>(r.place->inliers))
            .bind(7, r.place->bow_score)
            .step();
      }
    }
    db_.exec("COMMIT");
  } catch (...) {
    db_.exec("ROLLBACK");
    throw;
  }
}

std::vector<KeyframeKey> AnalysisStore::unanalysed(std::size_t limit,
                                                   const std::vector<KeyframeKey>& exclude) const {
  const std::set<KeyframeKey> skip(exclude.begin(), exclude.end());
  auto query = db_.prepare(
      "SELECT k.robot_id, k.sequence_number FROM keyframes k LEFT JOIN keyframe_analysis a "
      "ON a.robot_id = k.robot_id AND a.sequence_number = k.sequence_number "
      "WHERE a.status IS NULL OR a.status = 'deferred' ORDER BY k.received_ns LIMIT ?");
  query.bind(1, static_cast<std::int64_t>(limit + skip.size()));
  std::vector<KeyframeKey> out;
  while (query.step() && out.size() < limit) {
    KeyframeKey key{query.text(0), static_cast<std::uint64_t>(query.int64(1))};
    if (!skip.count(key)) out.push_back(std::move(key));
  }
  return out;
}

namespace {

StoredWord word_from_row(const SqliteStatement& row) {
  StoredWord w;
  w.keyframe = {row.text(0), static_cast<std::uint64_t>(row.int64(1))};
  w.capture_time_ns = row.int64(2);
  w.text = row.text(3);
  w.confidence = row.real(4);
  w.box = cv::Rect(static_cast<int>(row.int64(5)), static_cast<int>(row.int64(6)),
                   static_cast<int>(row.int64(7)), static_cast<int>(row.int64(8)));
  return w;
}

constexpr const char* kWordColumns =
    "w.robot_id, w.sequence_number, k.capture_time_ns, w.text, w.confidence, w.x, w.y, w.width, "
    "w.height";

}  // namespace

std::vector<StoredWord> AnalysisStore::search_words(const std::string& text,
                                                    std::size_t limit) const {
  auto query = db_.prepare(std::string("SELECT ") + kWordColumns +
                           " FROM words_fts f JOIN words w ON w.word_id = f.rowid JOIN keyframes k "
                           "ON k.robot_id = w.robot_id AND k.sequence_number = w.sequence_number "
                           "WHERE words_fts MATCH ? ORDER BY f.rank, w.confidence DESC LIMIT ?");
  query.bind(1, text).bind(2, static_cast<std::int64_t>(limit));
  std::vector<StoredWord> out;
  while (query.step()) out.push_back(word_from_row(query));
  return out;
}

std::vector<StoredWord> AnalysisStore::words() const {
  auto query = db_.prepare(std::string("SELECT ") + kWordColumns +
                           " FROM words w JOIN keyframes k ON k.robot_id = w.robot_id AND "
                           "k.sequence_number = w.sequence_number ORDER BY w.word_id");
  std::vector<StoredWord> out;
  while (query.step()) out.push_back(word_from_row(query));
  return out;
}

std::vector<StoredPlaceMatch> AnalysisStore::place_matches() const {
  auto query = db_.prepare(
      "SELECT robot_id, sequence_number, match_robot_id, match_sequence_number, matches, "
      "inliers, bow_score FROM place_matches ORDER BY robot_id, sequence_number");
  std::vector<StoredPlaceMatch> out;
  while (query.step()) {
    StoredPlaceMatch m;
    m.query = {query.text(0), static_cast<std::uint64_t>(query.int64(1))};
    m.match = {query.text(2), static_cast<std::uint64_t>(query.int64(3))};
    m.matches = static_cast<std::size_t>(query.int64(4));
    m.inliers = static_cast<std::size_t>(query.int64(5));
    m.bow_score = query.real(6);
    out.push_back(std::move(m));
  }
  return out;
}

std::vector<AnalysisStore::StoredFeatures> AnalysisStore::features() const {
  // A database written before place descriptors were stored (opened read-only) lacks their
  // table: its keyframes come without descriptors.
  auto has_descriptors =
      db_.prepare("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?");
  has_descriptors.bind(1, std::string("keyframe_descriptors"));
  const std::string descriptors =
      has_descriptors.step()
          ? "d.dimensions, d.descriptor FROM keyframe_features f LEFT JOIN keyframe_descriptors d "
            "ON d.robot_id = f.robot_id AND d.sequence_number = f.sequence_number"
          : "0, NULL FROM keyframe_features f";
  auto query = db_.prepare(
      "SELECT f.robot_id, f.sequence_number, a.capture_time_ns, f.count, f.keypoints, "
      "f.descriptors, " +
      descriptors +
      " JOIN keyframe_analysis a ON a.robot_id = f.robot_id "
      "AND a.sequence_number = f.sequence_number WHERE a.status = 'done' "
      "ORDER BY a.analysed_order");
  std::vector<StoredFeatures> out;
  while (query.step()) {
    StoredFeatures f;
    f.key = {query.text(0), static_cast<std::uint64_t>(query.int64(1))};
    f.capture_time_ns = query.int64(2);
    const int count = static_cast<int>(query.int64(3));
    f.features.keypoints = unpack_keypoints(query.blob(4));
    const std::vector<std::uint8_t> descriptors = query.blob(5);
    if (count > 0 && descriptors.size() == static_cast<std::size_t>(count) * 32 &&
        f.features.keypoints.size() == static_cast<std::size_t>(count)) {
      f.features.descriptors = cv::Mat(count, 32, CV_8U);
      std::memcpy(f.features.descriptors.data, descriptors.data(), descriptors.size());
    } else {
      f.features.keypoints.clear();
    }
    const std::vector<std::uint8_t> descriptor = query.blob(7);
    const auto dimensions = static_cast<std::size_t>(std::max<std::int64_t>(0, query.int64(6)));
    if (dimensions > 0 && descriptor.size() == dimensions * sizeof(float)) {
      f.descriptor.resize(dimensions);
      std::memcpy(f.descriptor.data(), descriptor.data(), descriptor.size());
    }
    out.push_back(std::move(f));
  }
  return out;
}

std::size_t AnalysisStore::count_with_status(AnalysisStatus status) const {
  auto query = db_.prepare("SELECT COUNT(*) FROM keyframe_analysis WHERE status = ?");
  query.bind(1, std::string(to_string(status)));
  query.step();
  return static_cast<std::size_t>(query.int64(0));
}

}  // namespace keyfleet::station
