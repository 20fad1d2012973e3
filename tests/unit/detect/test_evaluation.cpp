// Detection scoring (VOC AP, precision, recall, height buckets), the annotated-folder reader and
// its errors, the train/eval split, and the PersonDetector on real frames and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ml.hpp>

#include "thermovis/detect/evaluation.hpp"
#include "thermovis/detect/infrared_classifier.hpp"
#include "thermovis/detect/person_detector.hpp"
#include "thermovis/test/data.hpp"

namespace dt = thermovis::detect;

namespace {

dt::Detection det(cv::Rect box, double score) {
  dt::Detection d;
  d.box = box;
  d.score = score;
  return d;
}

void write_text(const std::filesystem::path& file, const std::string& text) {
  std::ofstream(file) << text;
}

}  // namespace

// Two people; ranked detections hit, miss, hit: precision 1, 1/2, 2/3 at recall 1/2, 1/2, 1.
// All-point interpolation: AP = 0.5 * 1 + 0.5 * 2/3.
TEST(DetectEvaluate, VocAllPointAp) {
  dt::FrameResult f;
  f.persons = {{0, 0, 10, 40}, {100, 0, 10, 40}};
  f.detections = {det({0, 0, 10, 40}, 0.9), det({50, 0, 10, 40}, 0.8), det({101, 1, 10, 40}, 0.7)};
  const dt::Figures r = dt::evaluate({f}, 0.5);
  EXPECT_EQ(r.persons, 2);
  EXPECT_EQ(r.detections, 3);
  EXPECT_EQ(r.true_positives, 2);
  EXPECT_NEAR(r.ap, 0.5 + 0.5 * 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(r.precision, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(r.recall, 1.0, 1e-12);
}

// A second box on a person already found is a false positive; a box on a bicycle (don't care)
// counts for nothing; a box on no one is a false positive.
TEST(DetectEvaluate, DuplicatesAndDontCare) {
  dt::FrameResult f;
  f.persons = {{0, 0, 10, 40}};
  f.dont_care = {{200, 0, 30, 20}};
  f.detections = {det({0, 0, 10, 40}, 0.9), det({0, 1, 10, 40}, 0.8), det({200, 0, 30, 20}, 0.7)};
  const dt::Figures r = dt::evaluate({f}, 0.5);
  EXPECT_EQ(r.detections, 2);
  EXPECT_EQ(r.true_positives, 1);
  EXPECT_NEAR(r.precision, 0.5, 1e-12);
  EXPECT_NEAR(r.ap, 1.0, 1e-12);  // the hit ranks first
}

// Per height bucket: people and detections matched to people of other heights are left out; an
// unmatched detection counts where its own height falls.
TEST(DetectEvaluate, HeightBuckets) {
  dt::FrameResult f;
  f.persons = {{0, 0, 8, 20}, {100, 0, 40, 100}};
  f.detections = {det({100, 0, 40, 100}, 0.9), det({300, 0, 20, 50}, 0.8)};
  const dt::Figures small = dt::evaluate({f}, 0.5, 0, 30);
  EXPECT_EQ(small.persons, 1);
  EXPECT_EQ(small.detections, 0);
  EXPECT_EQ(small.recall, 0.0);
  const dt::Figures middle = dt::evaluate({f}, 0.5, 30, 80);
  EXPECT_EQ(middle.persons, 0);
  EXPECT_EQ(middle.detections, 1);
  EXPECT_EQ(middle.precision, 0.0);
  const dt::Figures large = dt::evaluate({f}, 0.5, 80, 1e9);
  EXPECT_EQ(large.persons, 1);
  EXPECT_EQ(large.detections, 1);
  EXPECT_NEAR(large.ap, 1.0, 1e-12);
  const dt::Figures all = dt::evaluate({f}, 0.5);
  EXPECT_NEAR(all.recall, 0.5, 1e-12);
  EXPECT_NEAR(all.precision, 0.5, 1e-12);
}

// A folder with one good frame and one of each fault: every fault is named with its file and
// entry, and the good frame is still read.
TEST(DetectFolder, BadEntriesAndImagesAreNamedAndSkipped) {
  const auto dir = thermovis::test::temp_dir("detect_folder");
  std::filesystem::create_directories(dir / "infrared");
  std::filesystem::create_directories(dir / "visible");
  cv::imwrite((dir / "infrared/good.png").string(), cv::Mat(40, 60, CV_8UC1, cv::Scalar(9)));
  cv::imwrite((dir / "infrared/raw.png").string(), cv::Mat(40, 60, CV_16UC1, cv::Scalar(9000)));
  cv::imwrite((dir / "infrared/colour16.png").string(), cv::Mat(40, 60, CV_16UC3));
  cv::imwrite((dir / "infrared/outside.png").string(), cv::Mat(40, 60, CV_8UC1));
  cv::imwrite((dir / "infrared/sized.png").string(), cv::Mat(40, 60, CV_8UC1));
  cv::imwrite((dir / "visible/sized.png").string(), cv::Mat(20, 30, CV_8UC3));
  write_text(dir / "infrared/broken.png", "not an image");
  write_text(dir / "infrared/badbox.png", "");
  write_text(dir / "boxes.json", R"({
    "good": [{"label": "person", "box": [1, 2, 11, 32]}, {"label": "car", "box": [20, 0, 40, 9]}],
    "raw": [],
    "colour16": [],
    "broken": [],
    "outside": [{"label": "person", "box": [50, 0, 70, 30]}],
    "sized": [],
    "badbox": [{"label": "person", "box": [5, 5, 5]}],
    "inverted": [{"label": "person", "box": [5, 5, 2, 9]}],
    "nolabel": [{"box": [0, 0, 2, 9]}],
    "missing": []
  })");
  const dt::AnnotatedSet set = dt::load_annotated_set(dir);
  auto has_error = [&](const std::string& a, const std::string& b) {
    for (const auto& e : set.errors) {
      if (e.find(a) != std::string::npos && e.find(b) != std::string::npos) return true;
    }
    return false;
  };
  EXPECT_TRUE(has_error("boxes.json", "\"badbox\": box 0"));
  EXPECT_TRUE(has_error("boxes.json", "\"inverted\": box 0"));
  EXPECT_TRUE(has_error("boxes.json", "\"nolabel\": box 0"));
  EXPECT_TRUE(has_error("infrared/missing", "\"missing\""));
  EXPECT_EQ(set.errors.size(), 4u);
  ASSERT_EQ(set.frames.size(), 6u);  // sorted by name
  const auto frame = [&](const std::string& name) {
    for (const auto& f : set.frames) {
      if (f.name == name) return f;
    }
    throw std::runtime_error("no frame " + name);
  };
  const dt::AnnotatedFrame good = frame("good");
  ASSERT_EQ(good.persons.size(), 1u);
  EXPECT_EQ(good.persons[0], cv::Rect(1, 2, 10, 30));  // edges [1, 2, 11, 32]
  EXPECT_TRUE(good.dont_care.empty());                 // a car is background
  EXPECT_EQ(dt::load_frame_images(good, false).infrared.type(), CV_8UC1);
  EXPECT_EQ(dt::load_frame_images(frame("raw"), false).infrared.type(), CV_16UC1);
  auto error_of = [](const dt::AnnotatedFrame& f, bool visible) -> std::string {
    try {
      dt::load_frame_images(f, visible);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error_of(frame("broken"), false).find("infrared/broken.png"), std::string::npos);
  EXPECT_NE(error_of(frame("colour16"), false).find("infrared/colour16.png"), std::string::npos);
  EXPECT_NE(error_of(frame("outside"), false).find("\"outside\""), std::string::npos);
  EXPECT_NE(error_of(frame("sized"), true).find("visible/sized.png"), std::string::npos);
  EXPECT_NE(error_of(good, true).find("visible/good"), std::string::npos);  // no visible image
  EXPECT_THROW(dt::parse_annotated_set("[1, 2]", dir), std::runtime_error);
  EXPECT_THROW(dt::parse_annotated_set("{", dir), std::runtime_error);
}

// The split hashes the name less its last character: FNV-1a of "a" is 0xe40c292c (even:
// trains), of "b" 0xe70c2de5 (odd: evaluates); ten consecutive frames stay together. Both
// shared sets have frames on both sides.
TEST(DetectSplit, ByNameHash) {
  EXPECT_TRUE(dt::is_training_frame("a0"));
  EXPECT_TRUE(dt::is_training_frame("a9"));
  EXPECT_FALSE(dt::is_training_frame("b0"));
  EXPECT_TRUE(dt::is_training_frame("010001"));
  EXPECT_TRUE(dt::is_training_frame("010009"));
  EXPECT_FALSE(dt::is_training_frame("010010"));
  for (const char* set : {"detect/llvip_dev", "detect/hituav_train"}) {
    const auto dir = thermovis::test::data_path(set);
    if (dir.empty()) continue;
    int train = 0, eval = 0;
    for (const auto& f : dt::load_annotated_set(dir).frames)
      ++(dt::is_training_frame(f.name) ? train : eval);
    EXPECT_GT(train, 10) << set;
    EXPECT_GT(eval, 10) << set;
  }
}

// The shipped classifier on the evaluation frames of LLVIP (never trained on): measured AP50
// 0.574, recall 0.780 (the warm-blob detector 0.443); asserted with a margin.
TEST(PersonDetector, ShippedClassifierOnRealEvalFrames) {
  THERMOVIS_REQUIRE_DATA(dir, "detect/llvip_dev");
  dt::PersonDetectorOptions o;
  o.infrared_model = thermovis::test::source_root() / "deploy/models/person_ir.yml.gz";
  dt::PersonDetector detector(o);
  std::vector<dt::FrameResult> results;
  for (const auto& frame : dt::load_annotated_set(dir).frames) {
    if (dt::is_training_frame(frame.name)) continue;
    dt::FrameResult r;
    r.detections = detector.detect(dt::load_frame_images(frame, false).infrared, cv::Mat());
    for (const auto& d : r.detections) {
      EXPECT_EQ(d.cls, "person");
      EXPECT_EQ(d.source, "infrared");
    }
    r.persons = frame.persons;
    results.push_back(std::move(r));
  }
  const dt::Figures f = dt::evaluate(results, 0.5);
  EXPECT_EQ(results.size(), 21u);
  EXPECT_GE(f.ap, 0.53);
  EXPECT_GE(f.recall, 0.70);
  // The same frames as raw 16-bit counts of a camera without gain control (an offset and a gain
  // per frame, as a 14-bit core gives): the detector stretches them itself and finds about as
  // many people.
  std::vector<dt::FrameResult> raw_results = results;
  std::size_t k = 0;
  for (const auto& frame : dt::load_annotated_set(dir).frames) {
    if (dt::is_training_frame(frame.name)) continue;
    cv::Mat counts;
    dt::load_frame_images(frame, false).infrared.convertTo(counts, CV_16U, 11.0 + k % 3, 6000.0);
    raw_results[k++].detections = detector.detect(counts, cv::Mat());
  }
  const dt::Figures raw = dt::evaluate(raw_results, 0.5);
  std::cout << "8-bit AP50 " << f.ap << ", raw counts AP50 " << raw.ap << "\n";
  // Measured: AP50 0.522 against 0.574 (the person model alone: 0.537 against 0.575).
  EXPECT_NEAR(raw.ap, f.ap, 0.07);
  EXPECT_NEAR(raw.recall, f.recall, 0.05);
}

// Two people standing shoulder to shoulder at the same warmth are one component at every
// threshold; the windows across it give each of them a candidate box that fits.
TEST(InfraredCandidates, TouchingPeopleGetABoxEach) {
  cv::Mat ir(200, 300, CV_8UC1, cv::Scalar(60));
  const cv::Rect left(100, 40, 40, 110), right(140, 45, 42, 105);
  ir(left).setTo(200);
  ir(right).setTo(200);
  const auto candidates = dt::infrared_candidates(ir);
  double best_left = 0, best_right = 0, best_union = 0;
  bool split = false;
  for (const auto& c : candidates) {
    best_left = std::max(best_left, dt::intersection_over_union(c.box, left));
    best_right = std::max(best_right, dt::intersection_over_union(c.box, right));
    best_union = std::max(best_union, dt::intersection_over_union(c.box, left | right));
    split = split || c.split;
  }
  EXPECT_TRUE(split);
  EXPECT_GE(best_left, 0.8);
  EXPECT_GE(best_right, 0.8);
  EXPECT_GE(best_union, 0.95);  // the component's own box is still a candidate
  // Without the windows only the pair's box exists: half of each person.
  dt::CandidateOptions no_split;
  no_split.split_widths.clear();
  double best = 0;
  for (const auto& c : dt::infrared_candidates(ir, no_split))
    best = std::max(best, dt::intersection_over_union(c.box, left));
  EXPECT_LT(best, 0.6);
}

// The 8-bit frame of raw counts: the field's 1st and 99.9th percentiles (of a 1-in-16
// subsample, by sorting here) stretched to 1..255, counts of 0 (outside the field) at 0.
TEST(InfraredTo8bit, StretchesTheFieldsPercentilesAsSortingGivesThem) {
  cv::RNG rng(11);
  for (const int range : {3, 200, 4000, 60000}) {
    cv::Mat counts(97, 131, CV_16UC1);
    rng.fill(counts, cv::RNG::UNIFORM, 1000, 1000 + range);
    counts(cv::Rect(0, 0, 40, 30)).setTo(0);  // outside the field
    counts.at<std::uint16_t>(48, 64) = 65535;
    std::vector<float> samples;
    for (int y = 0; y < counts.rows; y += 4)
      for (int x = 0; x < counts.cols; x += 4)
        if (counts.at<std::uint16_t>(y, x) > 0) samples.push_back(counts.at<std::uint16_t>(y, x));
    std::sort(samples.begin(), samples.end());
    const auto at = [&](double p) {
      const double n = static_cast<double>(samples.size());
      return static_cast<double>(
          samples[static_cast<std::size_t>(std::clamp(p / 100.0 * (n - 1.0), 0.0, n - 1.0))]);
    };
    const double lo = at(1.0);
    const double hi = std::max(lo + 1.0, at(99.9));
    const double gain = 254.0 / (hi - lo);
    cv::Mat want;
    counts.convertTo(want, CV_8U, gain, 1.0 - lo * gain);
    cv::max(want, 1, want);
    want.setTo(0, counts == 0);
    const cv::Mat got = dt::infrared_to_8bit(counts);
    ASSERT_EQ(got.type(), CV_8UC1);
    EXPECT_EQ(cv::countNonZero(got != want), 0) << "counts over " << range;
  }
  // Fewer than 16 samples in the field: all 0.
  cv::Mat sparse(16, 16, CV_16UC1, cv::Scalar(0));
  sparse.at<std::uint16_t>(0, 0) = 500;
  EXPECT_EQ(cv::countNonZero(dt::infrared_to_8bit(sparse)), 0);
}

// The mosaic's descriptors are each window's own (one compute() call per window), to the bit:
// textured and flat windows, counts that fill a mosaic row exactly, leave a part row, or span
// several rows.
TEST(HogMosaic, DescriptorsAreEachWindowsAlone) {
  const cv::HOGDescriptor hog(cv::Size(20, 20), cv::Size(10, 10), cv::Size(5, 5), cv::Size(5, 5),
                              9);
  cv::RNG rng(3);
  for (const int count : {1, 63, 64, 65, 130}) {
    std::vector<cv::Mat> windows;
    dt::HogMosaic mosaic(hog, count);
    for (int i = 0; i < count; ++i) {
      cv::Mat w(hog.winSize, CV_8UC1);
      rng.fill(w, cv::RNG::UNIFORM, 0, 256);
      cv::GaussianBlur(w, w, cv::Size(3, 3), 0.5 + (i % 4) * 0.5);
      if (i % 7 == 0) w.setTo(90);  // flat: no gradient at all
      w.copyTo(mosaic.scratch());
      mosaic.set(i);
      windows.push_back(w);
    }
    const std::vector<float> all = mosaic.compute();
    const std::size_t size = hog.getDescriptorSize();
    ASSERT_EQ(all.size(), static_cast<std::size_t>(count) * size);
    std::vector<float> alone;
    for (int i = 0; i < count; ++i) {
      hog.compute(windows[static_cast<std::size_t>(i)], alone);
      ASSERT_EQ(alone.size(), size);
      for (std::size_t k = 0; k < size; ++k) {
        ASSERT_EQ(all[static_cast<std::size_t>(i) * size + k], alone[k])
            << count << " windows, window " << i << ", value " << k;
      }
    }
  }
  dt::HogMosaic mosaic(hog, 2);
  EXPECT_THROW(mosaic.set(2), std::out_of_range);
  mosaic.scratch() = cv::Mat(10, 10, CV_8UC1);
  EXPECT_THROW(mosaic.set(0), std::invalid_argument);
  EXPECT_TRUE(dt::HogMosaic(hog, 0).compute().empty());
}

TEST(PersonDetector, BadInput) {
  dt::PersonDetectorOptions o;
  o.band = dt::Band::fused;
  dt::PersonDetector fused(o);
  const cv::Mat ir(40, 60, CV_8UC1, cv::Scalar(0)), vis(40, 60, CV_8UC3, cv::Scalar(0));
  EXPECT_NO_THROW(fused.detect(ir, vis));
  EXPECT_THROW(fused.detect(ir, cv::Mat()), std::invalid_argument);
  EXPECT_THROW(fused.detect(cv::Mat(40, 60, CV_32F), vis), std::invalid_argument);
  EXPECT_THROW(fused.detect(ir, cv::Mat(20, 60, CV_8UC3)), std::invalid_argument);
  o.band = dt::Band::infrared;
  o.infrared_model = "/nonexistent/model.yml.gz";
  EXPECT_THROW(dt::PersonDetector{o}, std::runtime_error);
  EXPECT_THROW(dt::parse_band("thermal"), std::invalid_argument);
}

namespace {

// A synthetic thermal frame: cool ground with noise, warm things that are not people (low wide
// slabs, round blobs) and people of a few sizes (warm torso and head, cooler legs), the people's
// boxes returned.
cv::Mat synthetic_people(unsigned seed, std::vector<cv::Rect>& persons) {
  cv::RNG rng(seed);
  cv::Mat ir(240, 400, CV_8UC1);
  rng.fill(ir, cv::RNG::NORMAL, 60, 5);
  for (int k = 0; k < 3; ++k) {
    const int w = rng.uniform(40, 90), h = rng.uniform(12, 30);
    ir(cv::Rect(rng.uniform(0, ir.cols - w), rng.uniform(0, ir.rows - h), w, h)).setTo(170);
    cv::circle(ir, cv::Point(rng.uniform(10, ir.cols - 10), rng.uniform(10, ir.rows - 10)),
               rng.uniform(4, 12), cv::Scalar(190), cv::FILLED);
  }
  persons.clear();
  for (int x = 10; x + 40 < ir.cols; x += 60 + rng.uniform(0, 30)) {
    const int h = rng.uniform(40, 130);
    const int w = std::max(8, static_cast<int>(0.35 * h));
    const int y = rng.uniform(0, ir.rows - h);
    const cv::Rect box(x, y, w, h);
    const int head = h / 7;
    cv::ellipse(ir, cv::Point(x + w / 2, y + head / 2), cv::Size(w / 5, head / 2), 0, 0, 360,
                cv::Scalar(210), cv::FILLED);
    ir(cv::Rect(x, y + head, w, h * 2 / 5)).setTo(195);
    ir(cv::Rect(x + w / 8, y + head + h * 2 / 5, w * 3 / 4, h - head - h * 2 / 5)).setTo(150);
    persons.push_back(box);
  }
  return ir;
}

}  // namespace

// Both models are trained from a frame's candidates and written to one file; on frames it was
// not trained on, of the candidates about a person the best-scored one fits it (the fit model
// ranks the person's box above its parts: its torso, its head).
TEST(InfraredClassifier, TrainsBothModelsAndTheBoxThatFitsAPersonRanksFirst) {
  dt::TrainingOptions t;
  t.weak_count = 30;
  t.fit_weak_count = 30;
  std::vector<dt::TrainingSample> samples;
  std::vector<cv::Rect> persons;
  int reachable = 0, total = 0;
  for (unsigned seed = 1; seed <= 8; ++seed) {
    const cv::Mat ir = synthetic_people(seed, persons);
    reachable += dt::collect_training_samples(ir, persons, {}, {}, t, samples);
    total += static_cast<int>(persons.size());
  }
  EXPECT_EQ(reachable, total);
  int people = 0, about = 0, background = 0;
  for (const auto& s : samples) {
    ASSERT_EQ(s.features.rows, 1);
    EXPECT_EQ(s.label == 1, s.person_iou >= t.positive_iou);
    ++(s.label == 1 ? people : s.person_iou >= t.fit_min_iou ? about : background);
  }
  EXPECT_GT(people, 0);
  EXPECT_GT(about, 0);
  EXPECT_GT(background, 0);
  const auto model = thermovis::test::temp_dir("ir_model") / "person_ir.yml.gz";
  dt::train_infrared_classifier(samples, t, model);
  const dt::InfraredClassifier classifier(model);
  int fitted = 0, judged = 0;
  for (unsigned seed = 101; seed <= 104; ++seed) {
    const cv::Mat ir = synthetic_people(seed, persons);
    const auto candidates = dt::infrared_candidates(ir);
    const auto scores = classifier.score(dt::candidate_features(ir, candidates));
    ASSERT_EQ(scores.size(), candidates.size());
    for (const cv::Rect& person : persons) {
      double best_score = -1e300, best_iou = 0;
      for (std::size_t i = 0; i < candidates.size(); ++i) {
        const double o = dt::intersection_over_union(candidates[i].box, person);
        if (o >= t.fit_min_iou && scores[i] > best_score) {
          best_score = scores[i];
          best_iou = o;
        }
      }
      ++judged;
      fitted += best_iou >= t.positive_iou && best_score > 0;
    }
  }
  ASSERT_GT(judged, 10);
  // Measured: 17 of 20 people; 6 of 20 when the person model's score alone ranks them.
  EXPECT_GE(fitted, judged * 3 / 4) << fitted << " of " << judged;
}

// A model file of one boosted-trees model (no "fit" node: written before the fit model
// existed) is refused naming the node and the retraining.
TEST(InfraredClassifier, AModelFileWithoutTheFitModelIsRefused) {
  cv::Mat data(40, 1, CV_32F), labels(40, 1, CV_32S);
  for (int i = 0; i < 40; ++i) {
    data.at<float>(i) = static_cast<float>(i);
    labels.at<int>(i) = i < 20 ? 0 : 1;
  }
  auto boost = cv::ml::Boost::create();
  boost->setWeakCount(3);
  boost->train(cv::ml::TrainData::create(data, cv::ml::ROW_SAMPLE, labels));
  const auto model = thermovis::test::temp_dir("old_model") / "person_ir.yml";
  boost->save(model.string());
  try {
    const dt::InfraredClassifier classifier(model);
    ADD_FAILURE() << "an old model file was accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(model.string()), std::string::npos) << what;
    EXPECT_NE(what.find("person"), std::string::npos) << what;
    EXPECT_NE(what.find("retrain"), std::string::npos) << what;
  }
}
