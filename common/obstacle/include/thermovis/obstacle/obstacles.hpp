#pragma once
// Obstacles of any class standing on the ground, from the stereo geometry alone (no learning):
// the stixel world (Badino, Franke, Pfeiffer 2009) on the wide rectified grid.
//
// Per pair (visible, infrared), on a reduced grid (the pipeline grid's rows from a little above
// the prior's horizon down to the ground min_distance_m ahead, averaged over reduction x
// reduction px):
//  1. dense disparity (dense_disparity.hpp), every pixel triangulated exactly on the grid
//     (range::triangulate's geometry, the right eye wherever it is);
//  2. the ground from the v-disparity about the prior (ground.hpp);
//  3. per column, from the bottom up, the first run of pixels that stand above the ground (more
//     than min_height_m and 3 sigma of the height's noise) at one disparity, whose base lies on
//     the ground and whose top is min_obstacle_height_m above it: that column's stixel, its top
//     where the disparity leaves the run; its distance the horizontal distance (along the
//     ground) of the run's median disparity; in a column without one, the first run whose
//     pixels stand only as a whole (its disparity a vertical surface's, not the ground's, along
//     its rows: a short far object, ObstacleOptions::vertical_max_share);
//  4. neighbouring stixels at about one distance are one obstacle, at its near face's distance;
//     the free space of a column is the distance to its stixel;
//  5. the visible pair, given its images (detect, detect_pair), matched again on the grid's own
//     pixels in a band of rows about the fitted horizon: its stixels at 18-45 m fill the reduced
//     columns without one, and the obstacles are clustered again (ObstacleOptions::far_band).
// Both pairs' obstacles are combined where their boxes overlap at one distance (inverse
// variance): either pair may be given alone, and both together give one list. A pair whose
// ground is not found gives its status and no obstacle (on the simulated empty road at night
// the infrared pair's: docs/obstacles.md).
//
// Frames and units: boxes and columns are px of the pipeline grid's left image (x = column,
// y = row, pixel centres at integers); positions in the reporting camera's frame (the left
// visible camera: the frame of thermovis/ranges), metres; distances horizontal (along the
// fitted ground) from that camera's centre.
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/obstacle/dense_disparity.hpp"
#include "thermovis/obstacle/ground.hpp"
#include "thermovis/range/ranging.hpp"

namespace thermovis::obstacle {

enum class PairBand { visible, infrared };
std::string band_name(PairBand band);
// Bits of Obstacle::bands.
inline constexpr unsigned kVisibleBit = 1u, kInfraredBit = 2u;
inline unsigned band_bit(PairBand band) {
  return band == PairBand::visible ? kVisibleBit : kInfraredBit;
}

// One pair on the pipeline grid: its ranging geometry (grid, baseline, left rectified frame in
// the rig frame, the right centre when off the grid's axis).
struct PairSetup {
  PairBand band = PairBand::visible;
  range::RangingGeometry geometry;
  // The pair's images are the pipeline grid reduced by this integer (the infrared pair's own
  // resolution on a fine grid); it must divide ObstacleOptions::reduction.
  int image_reduction = 1;
};

struct ObstacleOptions {
  int reduction = 2;                // grid px per reduced px, each way (an integer: >= 1)
  double above_horizon_rad = 0.12;  // rows kept above the prior's horizon (obstacles' tops)
  double min_distance_m = 2.5;      // the nearest obstacle searched (disparity range, bottom row)
  double max_distance_m = 60.0;     // stixels farther are dropped; free space where none
  DenseOptions dense;
  // DenseOptions::texture_noise_factor for infrared counts (CV_16UC1), matched as their local
  // detail stretched to a fixed spread (grey_pair): there the noise estimate is a share of the
  // detail, not the sensor's level, and the real thermal pair of the MS2 road frame (ground
  // and van found with the fixed threshold) keeps 2.5 % of its pixels at 2.5. At 1.5 a block of
  // noise alone (its texture's spread over 49 px about a sixth of its mean) passes in well
  // under 1 of 1000; the simulated cameras' fixed pattern, the whole detail, passes nowhere.
  double counts_texture_noise_factor = 1.5;
  // A pair whose right eye is off the grid's axis (the infrared pair registered onto the
  // visible grid; its rows aligned to the prior ground's: Pair::right_map_y) is matched with a
  // stricter uniqueness than DenseOptions::uniqueness_ratio, and a block's disparity dropped
  // where its gradient across the rows (x Sobel) is under off_axis_min_across_share of its
  // gradient down them (0: kept): along such an edge (the horizon, tilted a degree or two on
  // the grid) a tenth of a pixel of row offset left moves the match by pixels. On the simulated
  // road (`thermovis bench obstacles --band infrared`, 50 empty-road frames) the default
  // uniqueness and no such test gave 276 false obstacles per 100 frames at night and 456 by
  // day; these, none (docs/obstacles.md). A pair rectified on its own baseline (on the axis)
  // keeps the defaults: on the real MS2 thermal pair the test would drop the van.
  int off_axis_uniqueness_ratio = 20;
  double off_axis_min_across_share = 0.5;
  // The largest correction of such a pair's disparity for the row offset the resampling at the
  // ground's distance leaves on a nearer point (obstacles.cpp); more: the disparity dropped.
  double off_axis_max_correction_px = 2.0;
  GroundOptions ground;
  double min_height_m = 0.15;             // a pixel this high above the ground (+ 3 sigma) stands
  double disparity_sigma_px = 0.25;       // one pixel's disparity noise, reduced px (height test)
  double systematic_disparity_px = 0.05;  // a stixel's disparity error that averaging keeps
  int min_stixel_rows = 5;                // pixels at one disparity that make a stixel
  double stixel_tolerance_px = 0.5;       // a pixel is at a stixel's disparity within this
  double stixel_tolerance_share = 0.06;   // + this share of it
  int max_gap_rows = 3;                   // rows without a disparity within a stixel
  double min_obstacle_height_m = 0.3;     // a stixel's top above the ground (+ 3 sigma)
  // A stixel's base at its disparity lies on the ground within min_obstacle_height_m, 3 sigma
  // and one reduced row above it, or this many rows (the block's smear) below it.
  double foot_rows = 4;
  // A run of pixels at one disparity of which fewer than min_stixel_rows stand one by one (a
  // far short object: a 0.5 m box at 20 m is 5 reduced rows, of which only the top 0.14 m are
  // above min_height_m + 3 sigma) is a stixel when it stands as a whole: each pixel above
  // min_height_m, the run's disparity gaining at most vertical_max_share of what the ground's
  // would from its top row down to its base, and that at least vertical_min_ground_gain_px (the
  // stixel world's object/ground test, Badino et al. 2009, on the run's slope). Only in a
  // column without a stixel of standing pixels, and from vertical_min_distance_m on (nearer,
  // anything min_obstacle_height_m tall has rows enough that stand one by one). The run must
  // span the matcher's block and vertical_min_rows_beyond_block more rows: one horizontal edge
  // (a lane dash's end) gives a block's rows of its disparity, upright to this test. 0: off.
  // Only for runs whose distance's ground lies at least vertical_min_rows_below_horizon
  // reduced rows below the horizon (about 31 m on the pipeline grid): nearer the horizon the
  // matcher's block covers the far road and the horizon's edge at one disparity, and the
  // empty road gave runs of 7-10 rows at 35-80 m that passed (294 false obstacles per 100
  // frames, `thermovis bench obstacles --scene obstacles`).
  double vertical_max_share = 0.35;
  double vertical_min_ground_gain_px = 1.0;
  double vertical_min_rows_below_horizon = 9.0;
  int vertical_min_rows_beyond_block = 3;
  double vertical_min_distance_m = 12.0;
  // Nor beyond this: on the full grid (`--grid-scale 1`) the empty road's vanishing point gave
  // such runs at 58-60 m, 6 per 100 frames.
  double vertical_max_distance_m = 45.0;
  int min_obstacle_columns = 2;           // stixels in an obstacle
  double max_sigma_share = 0.08;          // its nearest stixel's sigma over its distance at most
  double cluster_tolerance_m = 0.5;       // neighbouring stixels in one obstacle: this far apart
  double cluster_tolerance_share = 0.08;  // + this share of their distance
  int max_cluster_gap_columns = 2;        // reduced columns without a stixel inside an obstacle
  // A pair that finds no ground of its own takes the other pair's (detect()). Off: on the
  // simulated street's empty road by day the infrared pair finds none of its own, and its
  // stixels on the visible pair's ground gave 86 false obstacles per 100 frames (0 without;
  // `thermovis bench obstacles --share-ground`, 2026-12-05).
  bool share_ground = false;
  // Each obstacle of the visible pair at least refine_min_distance_m away whose near face (the
  // stixels within 2 sigma of its nearest) is at most refine_max_columns stixels wide is ranged
  // again at the grid's own resolution, `reduction` times finer than the stixels: that face's
  // rows and columns aligned between the eyes as one region (match::align_region, within 2 px
  // of the stixels' median disparity), its distance that of the region's centroid. A narrow
  // object's stixels mix it with what is beside it in every block (the 0.2 m pole at 18 m: 7 %
  // short, `thermovis bench obstacles --scene obstacles`). Wider ones keep the stixels' near
  // face: a region of a car averages its depth, farther than its nearest point. Kept when the
  // alignment fails or moves the disparity by more than refine_max_change_px; the sigma the
  // alignment's with refine_systematic_px added.
  bool refine = true;
  double refine_min_distance_m = 12.0;
  int refine_max_columns = 4;
  double refine_max_change_px = 2.0;   // grid px
  double refine_systematic_px = 0.05;  // grid px
  // The visible pair matched again on the grid itself (not reduced) in a band of rows about
  // the fitted ground's horizon, down to the ground far_band_min_distance_m ahead: there a
  // 0.5 m box at 30-40 m is 7-5 rows tall, over the matcher's block, where on the reduced grid
  // it is 3.5-2.6. Its stixels at far_band_min_distance_m or more fill the reduced columns
  // without one (the nearest of each column's `reduction` grid columns), and the obstacles are
  // clustered again.
  bool far_band = true;
  double far_band_min_distance_m = 18.0;
  double far_band_max_distance_m = 45.0;
};

// The first obstacle of one reduced column.
struct Stixel {
  int column = 0;                 // reduced grid column
  int base_row = 0, top_row = 0;  // pipeline grid rows of its bottom and top pixels
  double disparity_px = 0;        // median, reduced px
  double distance_m = 0;          // horizontal, from the reporting camera
  double sigma_m = 0;
  double height_m = 0;                                 // its top above the ground
  Eigen::Vector3d middle_m = Eigen::Vector3d::Zero();  // its middle point, reporting frame
};

struct Obstacle {
  cv::Rect box;  // pipeline grid, left image, px
  // Horizontal distance of its near face, m: the median of its stixels within 2 sigma of the
  // nearest one (the nearest alone is biased near: the least of several noisy distances).
  double distance_m = 0;
  double sigma_m = 0;                                    // one sigma of distance_m
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // centroid of its stixels' middles
  // Width across the line of sight (its end stixels apart, horizontally), height (its tallest
  // stixel's top above the ground), depth (its farthest stixel - its nearest), m.
  Eigen::Vector3d extent_m = Eigen::Vector3d::Zero();
  unsigned bands = 0;  // kVisibleBit | kInfraredBit
  int stixels = 0;
};

struct PairObstacles {
  PairBand band = PairBand::visible;
  GroundFit ground;                // the pair's left rectified frame
  bool ground_from_other = false;  // the other pair's ground (the pair found none of its own)
  // Found by the search about the last frame's ground (detect with GroundTracks).
  bool ground_tracked = false;
  GroundPlane ground_reporting;  // the same plane in the reporting frame
  std::vector<Stixel> stixels;   // every column's (also those no obstacle keeps)
  std::vector<Obstacle> obstacles;
  // Per obstacle (same order): its stixels, indices [first, second) into `stixels`.
  std::vector<std::pair<int, int>> obstacle_stixels;
  // Per pipeline grid column: distance to the first obstacle, m; max_distance_m where there is
  // none; NaN everywhere when the ground was not found.
  std::vector<float> free_space_m;
  bool ok() const { return ground.ok(); }
};

struct ObstacleResult {
  std::vector<PairObstacles> pairs;  // the pairs given images, in setup order
  std::vector<Obstacle> obstacles;   // both pairs combined
  // Per grid column: the nearest of the pairs that found the ground; NaN where none did.
  std::vector<float> free_space_m;
  bool ok() const;  // some pair found the ground
};

// Each pair's GroundTracker (ground.hpp) over the frames of one camera stream, for
// ObstacleDetector::detect(..., tracks): made on a pair's first frame.
class GroundTracks {
 public:
  explicit GroundTracks(const GroundTrackerOptions& options = {}) : options_(options) {}
  GroundTracker& of(PairBand band);
  void reset();  // every pair's search about its prior again (a new stream, the rig moved)

 private:
  GroundTrackerOptions options_;
  std::vector<std::pair<PairBand, GroundTracker>> trackers_;
};

class ObstacleDetector {
 public:
  // `grid`: the pipeline grid; `pairs` on it (at most one per band); `T_ref_reporting` the
  // reporting camera's pose in the rig frame. Throws std::invalid_argument for an empty grid, a
  // pair twice, a reduction < 1, or a prior that is not one (prior_plane).
  ObstacleDetector(const camera::RectifiedIntrinsics& grid, std::vector<PairSetup> pairs,
                   const Eigen::Isometry3d& T_ref_reporting, const GroundPrior& prior,
                   const ObstacleOptions& options = {});

  const ObstacleOptions& options() const { return options_; }
  // The reduced grid a pair's disparity is on (its rows start at first_grid_row() of the grid).
  const camera::RectifiedIntrinsics& reduced_grid(PairBand band) const;
  int first_grid_row(PairBand band) const;
  double max_disparity_px() const { return max_disparity_px_; }  // reduced px
  bool has(PairBand band) const;

  // One pair's rectified images on the pipeline grid reduced by its image_reduction (CV_8UC1,
  // CV_8UC3 or CV_16UC1 counts).
  // Throws std::invalid_argument for a band not set up or images of another size or type.
  PairObstacles detect_pair(PairBand band, const cv::Mat& left, const cv::Mat& right) const;
  // The same, the ground searched about `tracker`'s last one (GroundTracker), which takes this
  // frame's: one tracker per pair and camera stream.
  PairObstacles detect_pair(PairBand band, const cv::Mat& left, const cv::Mat& right,
                            GroundTracker& tracker) const;
  // The same from a disparity already on the pair's reduced grid (CV_32FC1, reduced px, NaN
  // where none): what detect_pair does after matching. With `rig_ground` (the rig frame) that
  // plane is the ground instead of the pair's own fit (GroundFit::message says so).
  PairObstacles from_disparity(PairBand band, const cv::Mat& disparity,
                               const GroundPlane* rig_ground = nullptr) const;
  // The pair's dense disparity on its reduced grid.
  cv::Mat disparity(PairBand band, const cv::Mat& left, const cv::Mat& right) const;
  // The dense options a pair's images are matched with: options().dense, for infrared counts
  // (CV_16UC1) with counts_texture_noise_factor.
  DenseOptions dense_options_for(const cv::Mat& left) const;
  // The reduced pair as the matcher reads it (grey, cropped and averaged).
  void reduce_pair(PairBand band, const cv::Mat& left, const cv::Mat& right, cv::Mat& left8,
                   cv::Mat& right8) const;

  // The pairs present (empty images: that pair skipped), combined. With share_ground, a pair
  // that finds no ground of its own takes the other's where that one found it.
  ObstacleResult detect(const cv::Mat& visible_left, const cv::Mat& visible_right,
                        const cv::Mat& infrared_left, const cv::Mat& infrared_right) const;
  // The same, each pair's ground searched about its ground of the last frame given to `tracks`
  // (narrower: GroundTracker), about the prior where there is none or that search fails; the
  // tracks take this frame's grounds.
  ObstacleResult detect(const cv::Mat& visible_left, const cv::Mat& visible_right,
                        const cv::Mat& infrared_left, const cv::Mat& infrared_right,
                        GroundTracks& tracks) const;
  // The same from each pair's disparity on its reduced grid.
  ObstacleResult from_disparities(
      const std::vector<std::pair<PairBand, cv::Mat>>& disparities) const;
  ObstacleResult from_disparities(const std::vector<std::pair<PairBand, cv::Mat>>& disparities,
                                  GroundTracks& tracks) const;
  ObstacleResult combine(std::vector<PairObstacles> pairs) const;

 private:
  struct Pair {
    explicit Pair(const PairSetup& s) : setup(s), reduced(s.geometry) {}
    PairSetup setup;
    range::RangingGeometry reduced;  // the geometry on the reduced grid
    int reduction = 1;               // grid px per reduced px (the far band: 1)
    int first_row = 0;               // pipeline grid row of the reduced grid's first row's top
    GroundPlane prior;               // in the pair's left rectified frame
    Eigen::Isometry3d T_reporting_rect = Eigen::Isometry3d::Identity();
    std::vector<double> row_beta;  // per reduced row, rad
    // sin and cos of the angle alpha of each reduced left column, and of the right eye's
    // columns from first_right_step / 16 px on in 1/16 px steps (NaN sine past 90 deg).
    std::vector<double> sin_left, cos_left, sin_right, cos_right;
    int first_right_step = 0;
    // A right eye off the grid's axis (the infrared pair registered onto the visible grid)
    // sees a point on another row than the left eye: per reduced left pixel, the right image's
    // row (CV_32FC1; x: the column itself) that holds the prior ground's point on its ray
    // (above the horizon: its point at infinity). Empty on the axis.
    cv::Mat right_map_x, right_map_y;
    // The right eye's row offset per px of disparity at each reduced left pixel (first order).
    cv::Mat right_row_per_disparity;
  };
  const Pair& pair(PairBand band) const;
  // Pair's angle tables (sin_left ... first_right_step) for disparities up to max_disparity_px.
  static void angle_tables(Pair& p, double max_disparity_px);
  // Pair::right_map_x and right_map_y of a pair whose right eye is off the grid's axis.
  void right_rows(Pair& p) const;
  // from_disparity; with a tracker, the ground searched about its last one first (detect).
  PairObstacles analyse(PairBand band, const cv::Mat& disparity, const GroundPlane* rig_ground,
                        GroundTracker* tracker) const;
  ObstacleResult detect_with(const cv::Mat& visible_left, const cv::Mat& visible_right,
                             const cv::Mat& infrared_left, const cv::Mat& infrared_right,
                             GroundTracks* tracks) const;
  ObstacleResult from_disparities_with(const std::vector<std::pair<PairBand, cv::Mat>>& disparities,
                                       GroundTracks* tracks) const;
  // Each pair's analysis, a pair without a ground on the other's where share_ground says.
  std::vector<PairObstacles> analyse_pairs(
      const std::vector<std::pair<PairBand, cv::Mat>>& disparities, GroundTracks* tracks) const;
  // ObstacleOptions::far_band on the visible pair's obstacles, from its images on the grid.
  void add_far_band(const Pair& p, const cv::Mat& left, const cv::Mat& right,
                    PairObstacles& out) const;
  // ObstacleOptions::refine on a pair's obstacles, from its images on the grid.
  void refine(const Pair& p, const cv::Mat& left, const cv::Mat& right, PairObstacles& out) const;
  // Each pixel's point (left rectified frame, NaN where it has none) into `points` (made the
  // disparity's size when it is not): the columns the ground is fitted on
  // (GroundOptions::column_step), or the others; of those, only the ones `columns` marks when
  // it is given (the others' points are left as they were).
  void triangulate(const Pair& p, const cv::Mat& disparity, cv::Mat& points, bool ground_columns,
                   const std::vector<bool>* columns = nullptr) const;
  // The columns' stixels (of those `columns` marks, when given: only their pixels are looked
  // at, and ground_pixels counts only theirs); ground_pixels: per reduced column, its pixels on
  // the ground.
  std::vector<Stixel> stixels(const Pair& p, const cv::Mat& disparity, const cv::Mat& points,
                              const GroundPlane& ground, const GroundPlane& ground_reporting,
                              std::vector<int>& ground_pixels,
                              const std::vector<bool>* columns = nullptr) const;
  // The obstacles of a pair's stixels; `spans` takes each one's stixels (PairObstacles::
  // obstacle_stixels).
  std::vector<Obstacle> cluster(const std::vector<Stixel>& stixels, PairBand band,
                                const GroundPlane& ground_reporting,
                                std::vector<std::pair<int, int>>& spans) const;

  camera::RectifiedIntrinsics grid_;
  std::vector<Pair> pairs_;
  // The visible pair on the grid itself (ObstacleOptions::far_band), its rows set per capture.
  std::optional<Pair> far_band_;
  Eigen::Isometry3d T_ref_reporting_;
  ObstacleOptions options_;
  double max_disparity_px_ = 0;
};

}  // namespace thermovis::obstacle
