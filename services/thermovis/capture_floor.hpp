#pragma once
// The CPU floor of one capture, the yardstick of the pipeline's CPU budget (`bench pipeline`,
// `bench stages`): one copy of every image of the capture plus cv::resize(INTER_AREA) of each
// to the grid, on this thread. What any frame path must at least spend to read its images once
// and write them on the grid.
#include <algorithm>
#include <ctime>
#include <opencv2/core/mat.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

namespace thermovis::cli {

// This thread's CPU time, ms.
inline double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

// OpenCV on this thread alone while it lives (its workers' CPU time is not this thread's), the
// thread count restored after.
class OneOpenCvThread {
 public:
  OneOpenCvThread() : threads_(cv::getNumThreads()) { cv::setNumThreads(1); }
  ~OneOpenCvThread() { cv::setNumThreads(threads_); }
  OneOpenCvThread(const OneOpenCvThread&) = delete;
  OneOpenCvThread& operator=(const OneOpenCvThread&) = delete;

 private:
  int threads_;
};

// CPU ms of the floor for one capture's images (a range of cv::Mat, the simulator's slots:
// visible left and right, infrared left and right) on the grids of `grid` px (visible) and
// `infrared_grid` px (the infrared pair's images: the grid reduced by its infrared reduction),
// the best of `repeats` runs (the first allocates the outputs; the machine is shared).
// OpenCV 4.6's INTER_AREA is vectorised only for whole-number ratios; onto a grid of another
// size it runs a generic weighted sum, so `interpolation` INTER_LINEAR gives the tighter floor
// (the bench prints both).
template <class Images>
double capture_floor_cpu_ms(const Images& images, cv::Size grid, cv::Size infrared_grid,
                            int repeats = 5, int interpolation = cv::INTER_AREA) {
  const OneOpenCvThread one_thread;
  cv::Mat copy, resized;
  double best = 1e300;
  for (int k = 0; k < repeats; ++k) {
    const double start = thread_cpu_ms();
    int slot = 0;
    for (const cv::Mat& image : images) {
      image.copyTo(copy);
      cv::resize(image, resized, slot++ < 2 ? grid : infrared_grid, 0, 0, interpolation);
    }
    best = std::min(best, thread_cpu_ms() - start);
  }
  return best;
}

}  // namespace thermovis::cli
