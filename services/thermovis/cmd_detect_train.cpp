// thermovis detect-train: trains the infrared person classifier on the training frames of
// annotated folders (the frames detect-eval never evaluates, see is_training_frame) and writes
// the model file the detector loads.
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <stdexcept>

#include "command.hpp"
#include "thermovis/detect/evaluation.hpp"
#include "thermovis/detect/infrared_classifier.hpp"

namespace {

namespace dt = thermovis::detect;

struct Options {
  std::vector<std::string> dirs;
  std::string out;
  dt::TrainingOptions training;
  bool mirror = false;
  std::string frames = "train";
};

int run_detect_train(const Options& opt) {
  std::vector<dt::TrainingSample> samples;
  int frames = 0, persons = 0, reachable = 0;
  for (const auto& dir : opt.dirs) {
    const dt::AnnotatedSet set = dt::load_annotated_set(dir);
    for (const auto& e : set.errors) std::cerr << "detect-train: " << e << "\n";
    for (const auto& frame : set.frames) {
      if (dt::is_training_frame(frame.name) != (opt.frames == "train")) continue;
      dt::FrameImages images;
      try {
        images = dt::load_frame_images(frame, false);
      } catch (const std::exception& e) {
        std::cerr << "detect-train: " << e.what() << "\n";
        continue;
      }
      reachable += dt::collect_training_samples(images.infrared, frame.persons, frame.dont_care,
                                                dt::CandidateOptions{}, opt.training, samples);
      if (opt.mirror) {
        // The frame mirrored left to right: people seen from the other side, twice the samples.
        const int w = images.infrared.cols;
        auto mirrored = [w](std::vector<cv::Rect> boxes) {
          for (cv::Rect& b : boxes) b.x = w - b.x - b.width;
          return boxes;
        };
        cv::Mat flipped;
        cv::flip(images.infrared, flipped, 1);
        dt::collect_training_samples(flipped, mirrored(frame.persons), mirrored(frame.dont_care),
                                     dt::CandidateOptions{}, opt.training, samples);
      }
      persons += static_cast<int>(frame.persons.size());
      ++frames;
    }
  }
  std::size_t positives = 0, about = 0;
  for (const auto& s : samples) {
    positives += static_cast<std::size_t>(s.label);
    about += static_cast<std::size_t>(s.label == 0 && s.person_iou >= opt.training.fit_min_iou);
  }
  std::cout << "training frames " << frames << ", persons " << persons
            << ", persons with a candidate at IoU >= " << opt.training.positive_iou << ": "
            << reachable << "; samples " << positives << " person, " << about
            << " about a person (IoU >= " << opt.training.fit_min_iou << "), "
            << samples.size() - positives - about << " background\n";
  dt::train_infrared_classifier(samples, opt.training, opt.out);
  std::cout << "wrote " << opt.out << " (" << std::filesystem::file_size(opt.out) << " bytes)\n";
  return 0;
}

THERMOVIS_COMMAND(
    "detect-train",
    "Trains the infrared person classifier on the training frames of annotated folders",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--dir", opt->dirs,
                     "annotated folder (infrared/, boxes.json); repeat for several. Only its "
                     "training frames are used: the FNV-1a 32-bit hash of the name less its last "
                     "character is even (detect-eval --frames eval takes the others)")
          ->required();
      app.add_option("--out", opt->out, "model file to write (.yml or .yml.gz)")->required();
      app.add_option("--positive-iou", opt->training.positive_iou,
                     "a candidate this close to a person box is a person sample")
          ->capture_default_str();
      app.add_option("--negative-iou", opt->training.negative_iou,
                     "one overlapping no person box this much is a background sample")
          ->capture_default_str();
      app.add_option("--max-negatives", opt->training.max_negatives_per_frame,
                     "background samples per frame, thinned evenly (0 = all)")
          ->capture_default_str();
      app.add_option("--frames", opt->frames,
                     "train (the shipped model's) or eval: the other half, to measure a model "
                     "trained on it on the train frames (detect-eval --frames train), a second "
                     "fold")
          ->check(CLI::IsMember({"train", "eval"}))
          ->capture_default_str();
      app.add_flag("--mirror", opt->mirror, "also train on every frame mirrored left to right");
      app.add_option("--weak-count", opt->training.weak_count, "boosted trees")
          ->capture_default_str();
      app.add_option("--max-depth", opt->training.max_depth, "depth of each tree")
          ->capture_default_str();
      app.add_option("--fit-weak-count", opt->training.fit_weak_count,
                     "boosted trees of the fit model (a box that fits a person against parts of "
                     "one and groups)")
          ->capture_default_str();
      app.add_option("--fit-min-iou", opt->training.fit_min_iou,
                     "the fit model's other class: candidates overlapping a person this much "
                     "that are not one")
          ->capture_default_str();
      return [opt] { return run_detect_train(*opt); };
    });

}  // namespace
