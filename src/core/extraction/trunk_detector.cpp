// Trunk detection: the steps of detect() and detectScan(), each in its own file (ground_model, trunk_clustering,
// tilt_estimator, trunk_fit, circle_fit).
#include "rbpf_slam/core/extraction/trunk_detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <Eigen/Eigenvalues>

#include "rbpf_slam/core/extraction/ground_model.h"
#include "rbpf_slam/core/extraction/stem_axis.h"
#include "rbpf_slam/core/extraction/tilt_estimator.h"
#include "rbpf_slam/core/extraction/trunk_clustering.h"
#include "rbpf_slam/core/extraction/trunk_fit.h"
#include "rbpf_slam/core/filter/random.h"

namespace rbpf_slam
{
namespace core
{
namespace
{
/** Wall time of consecutive stages. */
class StageTimer
{
public:
  /** Adds the time since the previous lap (or the start) to @p acc [ms]. */
  void lap(double* acc)
  {
    const auto now = std::chrono::steady_clock::now();
    *acc += std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
  }

private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

/** The finite points, rotated by @p level into the levelled frame. */
void levelFinitePoints(const std::vector<Eigen::Vector3f>& points, const Eigen::Matrix3d& level,
                       std::vector<Eigen::Vector3d>* out)
{
  out->clear();
  out->reserve(points.size());
  for (const auto& pf : points)
    if (pf.allFinite())
      out->push_back(level * pf.cast<double>());
}

/** A candidate's horizontal projection after removing the tilt (shear about the sensor origin). */
void levelCandidate(const TrunkCandidate& candidate, const Eigen::Vector2d& tilt, std::vector<Eigen::Vector2d>* out)
{
  out->clear();
  out->reserve(candidate.points.size());
  for (const auto& q : candidate.points)
    out->emplace_back(q.x() + tilt.x() * q.z(), q.y() + tilt.y() * q.z());
}

/**
 * The stems of one cluster (levelled points): when one circle explains its horizontal projection poorly and two
 * touching trunks explain it (fitTrunkPair(), as for the cluster fit), the stems of each of the two parts, else (or
 * when the parts give none) the stems of the whole (fitStemAxes()).
 */
std::vector<StemAxisFit> stemsOfCluster(const std::vector<Eigen::Vector3d>& levelled, const TrunkDetectorConfig& cfg,
                                        Random* rng, StemAxisRejection* why, const NearestReturns* occluders)
{
  std::vector<Eigen::Vector2d> p2;
  p2.reserve(levelled.size());
  for (const auto& q : levelled)
    p2.push_back(q.head<2>());
  const TrunkFit fit = fitTrunk(p2, cfg);
  if (isPoorSingleFit(p2, fit, checkTrunkFit(fit, static_cast<int>(p2.size()), cfg), cfg))
  {
    const TrunkPairFit pair = fitTrunkPair(p2, fit, cfg);
    std::vector<StemAxisFit> stems;
    for (int k = 0; pair.ok && k < 2; ++k)
    {
      std::vector<Eigen::Vector3d> part;
      for (int i : pair.members[k])
        part.push_back(levelled[static_cast<std::size_t>(i)]);
      for (auto& stem : fitStemAxes(part, cfg, rng, why, occluders))
        stems.push_back(std::move(stem));
    }
    if (!stems.empty())
      return stems;
  }
  return fitStemAxes(levelled, cfg, rng, why, occluders);
}

/**
 * The rotation that levels a sweep tilted by @p tilt (the shift of a vertical axis per metre up in the sensor's
 * frame): the vertical's direction (-tilt.x, -tilt.y, 1) turned onto +z, without yaw. To first order x += tilt.x z,
 * y += tilt.y z, z -= tilt . (x, y); the shear alone would stretch ranges by tilt^2 / 2 (4 cm at 10 m and 5 deg).
 */
Eigen::Matrix3d levelling(const Eigen::Vector2d& tilt)
{
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d(-tilt.x(), -tilt.y(), 1.0), Eigen::Vector3d::UnitZ())
      .toRotationMatrix();
}

/**
 * The stems of every candidate (fitStemAxes()), each with its cluster's point count in @p cluster_points, after
 * levelling the points by the small tilt @p tilt (levelling()); rejections into @p st when given. @p max_lean
 * overrides config.max_stem_lean.
 */
std::vector<StemAxisFit> fitStemColumns(const std::vector<TrunkCandidate>& candidates,
                                        const std::vector<Eigen::Vector3d>& sweep, const Eigen::Vector2d& tilt,
                                        TrunkDetectorConfig cfg, double max_lean, std::vector<int>* cluster_points,
                                        TrunkDetectorStats* st)
{
  cfg.max_stem_lean = max_lean;
  Random rng(cfg.seed);
  const Eigen::Matrix3d level = levelling(tilt);
  std::vector<Eigen::Vector3d> all_levelled;
  all_levelled.reserve(sweep.size());
  for (const auto& q : sweep)
    all_levelled.push_back(level * q);
  NearestReturns occluders;
  occluders.build(all_levelled);
  std::vector<StemAxisFit> all;
  std::vector<Eigen::Vector3d> levelled;
  for (const auto& c : candidates)
  {
    levelled.clear();
    for (const auto& q : c.points)
      levelled.push_back(level * q);
    StemAxisRejection why = StemAxisRejection::kNone;
    const std::vector<StemAxisFit> stems = stemsOfCluster(levelled, cfg, &rng, &why, &occluders);
    for (const auto& s : stems)
    {
      cluster_points->push_back(static_cast<int>(levelled.size()));
      all.push_back(s);
    }
    if (!st)
      continue;
    st->split_clusters += stems.size() > 1 ? 1 : 0;
    if (!stems.empty())
      continue;
    switch (why)
    {
      case StemAxisRejection::kRadius:
        ++st->rejected_radius;
        break;
      case StemAxisRejection::kInliers:
      case StemAxisRejection::kSize:
        ++st->rejected_inliers;
        break;
      case StemAxisRejection::kClutter:
        ++st->rejected_clutter;
        break;
      default:
        ++st->rejected_shape;
    }
  }
  return all;
}

/**
 * The sensor's residual tilt from @p stems fitted after levelling by @p start (with a lean of up to twice
 * config.max_stem_lean): the median of their leans per axis (the stems' own leans scatter about the vertical; the
 * median keeps a few bent or misfitted ones from pulling it). Even one stem's axis gives the tilt better than the
 * trunk clusters' start: a stem leans a few degrees, while a cluster's axis through branches and foliage often errs
 * by more (docs/trunk_extraction.md). @p start without stems.
 */
Eigen::Vector2d tiltFromStemAxes(const std::vector<StemAxisFit>& stems, const Eigen::Vector2d& start)
{
  if (stems.empty())
    return start;
  std::vector<double> lx, ly;
  for (const auto& s : stems)
  {
    lx.push_back(s.lean.x());
    ly.push_back(s.lean.y());
  }
  const auto median = [](std::vector<double>* v) {
    const std::size_t m = v->size() / 2;
    std::nth_element(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(m), v->end());
    double med = (*v)[m];
    if (v->size() % 2 == 0)
      med = 0.5 * (med + *std::max_element(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(m)));
    return med;
  };
  // The stems' median axis is the vertical: in the sensor's frame (-tilt, 1) points along it.
  const Eigen::Vector3d up = levelling(start).transpose() * Eigen::Vector3d(median(&lx), median(&ly), 1.0);
  return -up.head<2>() / up.z();
}

/**
 * @p stem fitted in a frame levelled by @p start, in the frame levelled by @p tilt instead (levelling()): its
 * centre, axis and heights turned by the rotation between the two.
 */
void levelStem(const Eigen::Vector2d& start, const Eigen::Vector2d& tilt, StemAxisFit* stem)
{
  const Eigen::Matrix3d turn = levelling(tilt) * levelling(start).transpose();
  const Eigen::Vector3d centre = turn * Eigen::Vector3d(stem->center.x(), stem->center.y(), stem->height);
  const Eigen::Vector3d axis = turn * Eigen::Vector3d(stem->lean.x(), stem->lean.y(), 1.0);
  const double dz = centre.z() - stem->height;
  stem->center = centre.head<2>();
  stem->lean = axis.head<2>() / axis.z();
  stem->height = centre.z();
  stem->z_lo += dz;
  stem->z_hi += dz;
}

/**
 * The tilt from the seen ground's plane @p ground (nullptr: none) or from the stems' median axis @p stems_tilt
 * (tiltFromStemAxes()) of @p n stems: the ground's when at least kMinStemsForGround stems agree with it, that is
 * depart from it by no more than their own leans explain (config.stem_lean_sigma per axis; the median's variance
 * pi/2 sigma^2 / n; chi-square of 2 degrees at 95 %). On level ground the ground's plane is the more precise (hundreds
 * of cells against a few stems that lean); on a slope the robot stands on, the ground is level in the sensor's frame
 * whatever gravity says, and the stems tell. One or two stems cannot tell a 10 % slope from their own lean (one must
 * depart by 7 deg before the test sees it): then their axes give the tilt; without stems, the ground does.
 */
Eigen::Vector2d chooseTilt(const Eigen::Vector2d* ground, const Eigen::Vector2d& stems_tilt, std::size_t n,
                           const TrunkDetectorConfig& cfg, TrunkDetectorStats* st)
{
  st->tilt_from_ground = false;
  if (!ground || !(cfg.stem_lean_sigma > 0.0))
    return stems_tilt;
  constexpr double kChi2Dof2P95 = 5.991;
  constexpr std::size_t kMinStemsForGround = 3;
  const double var = 0.5 * M_PI * cfg.stem_lean_sigma * cfg.stem_lean_sigma / std::max<double>(1.0, n);
  if ((n > 0 && n < kMinStemsForGround) || (stems_tilt - *ground).squaredNorm() / var > kChi2Dof2P95)
    return stems_tilt;
  st->tilt_from_ground = true;
  return *ground;
}

/**
 * The stems of every candidate as columns (fitStemColumns()) into @p out, in one fit: levelled by the trunks' tilt
 * @p start, the stems may lean twice as much as max_stem_lean; with config.level_by_trunks the tilt of the seen
 * ground @p ground (nullptr: none) or the median of their axes (chooseTilt()) then levels the stems themselves, and
 * those leaning more than max_stem_lean are dropped. The tilt used.
 */
Eigen::Vector2d stemColumns(const std::vector<TrunkCandidate>& candidates, const std::vector<Eigen::Vector3d>& sweep,
                            const Eigen::Vector2d& start, const Eigen::Vector2d* ground,
                            const TrunkDetectorConfig& cfg, std::vector<TrunkObservation>* out,
                            TrunkDetectorStats* st)
{
  const double max_lean = cfg.level_by_trunks ? 2.0 * cfg.max_stem_lean : cfg.max_stem_lean;
  std::vector<int> cluster_points;
  std::vector<StemAxisFit> stems = fitStemColumns(candidates, sweep, start, cfg, max_lean, &cluster_points, st);
  const Eigen::Vector2d tilt =
      cfg.level_by_trunks ? chooseTilt(ground, tiltFromStemAxes(stems, start), stems.size(), cfg, st) : start;
  for (std::size_t i = 0; i < stems.size(); ++i)
  {
    levelStem(start, tilt, &stems[i]);
    if (stems[i].lean.norm() > std::tan(cfg.max_stem_lean))
      ++st->rejected_shape;
    else
      out->push_back(toTrunkObservation(stems[i], cluster_points[i]));
  }
  return tilt;
}

TiltEstimatorParams tiltParams(const TrunkDetectorConfig& cfg)
{
  TiltEstimatorParams p;
  p.min_radius = cfg.min_radius;
  p.max_radius = cfg.max_radius;
  p.range_sigma = cfg.range_sigma;
  p.max_tilt = cfg.max_tilt;
  return p;
}
}  // namespace

bool parseTrunkMethod(const std::string& text, TrunkMethod* method)
{
  if (text == "centroid")
    *method = TrunkMethod::kCentroid;
  else if (text == "circle")
    *method = TrunkMethod::kCircle;
  else
    return false;
  return true;
}

const char* trunkMethodName(TrunkMethod method)
{
  switch (method)
  {
    case TrunkMethod::kCentroid:
      return "centroid";
    case TrunkMethod::kCircle:
      return "circle";
    case TrunkMethod::kArc:
      return "arc";
  }
  return "unknown";
}

std::string TrunkDetectorConfig::validate() const
{
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (method != TrunkMethod::kCentroid && method != TrunkMethod::kCircle)
    return "method must be centroid or circle";
  if (!positive(ground_cell))
    return "ground_cell must be > 0";
  if (!(ground_max_slope >= 0.0))
    return "ground_max_slope must be >= 0";
  if (!(ground_relief >= 0.0))
    return "ground_relief must be >= 0";
  if (!std::isfinite(min_height) || !std::isfinite(max_height) || !(max_height > min_height))
    return "max_height must be > min_height";
  if (!(voxel_size >= 0.0))
    return "voxel_size must be >= 0";
  if (!positive(cluster_tolerance))
    return "cluster_tolerance must be > 0";
  if (min_points < 3)
    return "min_points must be >= 3";
  if (scan_min_beams < 1)
    return "scan_min_beams must be >= 1";
  if (!positive(scan_min_jump))
    return "scan_min_jump must be > 0";
  if (max_points < min_points)
    return "max_points must be >= min_points";
  if (!positive(min_radius) || !(max_radius > min_radius))
    return "min_radius must be > 0 and max_radius > min_radius";
  if (!positive(ransac_threshold))
    return "ransac_threshold must be > 0";
  if (ransac_iterations < 1)
    return "ransac_iterations must be >= 1";
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0))
    return "min_inlier_ratio must be in [0, 1]";
  if (!(min_vertical_extent >= 0.0))
    return "min_vertical_extent must be >= 0";
  if (!positive(max_tilt))
    return "max_tilt must be > 0";
  if (!positive(slice_height))
    return "slice_height must be > 0";
  if (min_slices < 1)
    return "min_slices must be >= 1";
  if (!positive(max_stem_lean) || !(max_stem_lean < 0.5 * M_PI))
    return "max_stem_lean must be in (0, pi/2) rad";
  if (!(stem_lean_sigma >= 0.0) || !(stem_lean_sigma < 0.5 * M_PI))
    return "stem_lean_sigma must be in [0, pi/2) rad";
  if (!(max_interior_share >= 0.0))
    return "max_interior_share must be >= 0";
  if (!(max_see_through >= 0.0 && max_see_through <= 1.0))
    return "max_see_through must be in [0, 1]";
  if (!(min_silhouette_coverage >= 0.0 && min_silhouette_coverage <= 1.0))
    return "min_silhouette_coverage must be in [0, 1]";
  if (max_stems_per_cluster < 1)
    return "max_stems_per_cluster must be >= 1";
  if (min_fit_points < 3)
    return "min_fit_points must be >= 3";
  if (!(min_fit_arc >= 0.0))
    return "min_fit_arc must be >= 0";
  if (!positive(arc_radius_prior) || !positive(arc_radius_sigma))
    return "arc_radius_prior and arc_radius_sigma must be > 0";
  if (!positive(range_sigma))
    return "range_sigma must be > 0";
  if (!std::isfinite(range_offset) || std::abs(range_offset) > 1.0)
    return "range_offset must be finite and within +-1 m";
  if (!(azimuth_resolution >= 0.0 && azimuth_resolution < M_PI))
    return "azimuth_resolution must be in [0, pi) rad (0: from the cloud)";
  if (!(sensor_reach >= 0.0) || !std::isfinite(sensor_reach))
    return "sensor_reach must be a finite number >= 0 (0: from azimuth_resolution or the cloud)";
  if (!(min_range >= 0.0) || !(max_range > min_range))
    return "max_range must be > min_range >= 0";
  if (!(detection_probability > 0.0 && detection_probability <= 1.0))
    return "detection_probability must be in (0, 1]";
  if (!(sensor_height >= 0.0))
    return "sensor_height must be >= 0 (0: unknown)";
  return "";
}

/** Buffers reused from one call to the next. */
struct TrunkDetector::Impl
{
  std::vector<Eigen::Vector3d> levelled;
  std::vector<Eigen::Vector2d> projected;
};

TrunkDetector::TrunkDetector(const TrunkDetectorConfig& config) : impl_(new Impl)
{
  setConfig(config);
}

TrunkDetector::~TrunkDetector() = default;

void TrunkDetector::setConfig(const TrunkDetectorConfig& config)
{
  const std::string error = config.validate();
  if (!error.empty())
    throw std::invalid_argument("TrunkDetector: " + error);
  config_ = config;
}

std::vector<TrunkObservation> TrunkDetector::detect(const std::vector<Eigen::Vector3f>& points,
                                                     const Eigen::Matrix3d& level, TrunkDetectorStats* stats)
{
  TrunkDetectorStats local_stats;
  TrunkDetectorStats* st = stats ? stats : &local_stats;
  *st = TrunkDetectorStats();
  st->input_points = static_cast<int>(points.size());
  const TrunkDetectorConfig& cfg = config_;
  std::vector<TrunkObservation> out;

  std::vector<Eigen::Vector3d>& pts = impl_->levelled;
  levelFinitePoints(points, level, &pts);
  st->finite_points = static_cast<int>(pts.size());
  if (pts.empty())
    return out;
  StageTimer timer;

  // Ground, and the band above it where trunks are clear of ground vegetation and below the crowns.
  GroundModel ground(cfg.ground_cell, cfg.sensor_height, cfg.ground_max_slope, cfg.ground_relief, cfg.max_range);
  ground.build(pts);
  Eigen::Vector2d slope;
  const bool plane = ground.groundPlane(&slope);
  if (plane)
  {
    st->ground_pitch = std::atan(slope.x());
    st->ground_roll = -std::atan(slope.y());
  }
  std::vector<Eigen::Vector3f> band = selectHeightBand(pts, &ground, cfg.min_height, cfg.max_height);
  detectorReach(cfg, cfg.sensor_reach > 0.0 || cfg.azimuth_resolution > 0.0 ? NAN : estimateAzimuthStep(band),
                &st->reach, &st->reach_source, &st->azimuth_step);
  if (cfg.voxel_size > 0.0)
    downsampleVoxels(&band, cfg.voxel_size);
  st->band_points = static_cast<int>(band.size());
  if (band.size() < static_cast<std::size_t>(cfg.min_points))
    return out;
  timer.lap(&st->ms_band);

  const std::vector<std::vector<int>> clusters = clusterHorizontal(band, cfg.cluster_tolerance);
  st->clusters = static_cast<int>(clusters.size());
  const std::vector<TrunkCandidate> candidates = selectTrunkCandidates(band, clusters, cfg, st);
  timer.lap(&st->ms_cluster);

  const bool columns = cfg.column_fit && cfg.method == TrunkMethod::kCircle;
  Eigen::Vector2d tilt = Eigen::Vector2d::Zero();
  if (cfg.level_by_trunks && cfg.method == TrunkMethod::kCircle)
    tilt = estimateTiltFromTrunks(candidates, tiltParams(cfg));
  timer.lap(&st->ms_tilt);
  if (columns)
    tilt = stemColumns(candidates, pts, tilt, plane ? &slope : nullptr, cfg, &out, st);
  st->tilt_pitch = std::atan(tilt.x());
  st->tilt_roll = -std::atan(tilt.y());

  std::vector<Eigen::Vector2d>& p2 = impl_->projected;
  for (const auto& c : candidates)
  {
    if (columns)
      break;
    levelCandidate(c, tilt, &p2);
    const int n = static_cast<int>(p2.size());
    const TrunkFit fit = fitTrunk(p2, cfg);
    const TrunkRejection rejection = checkTrunkFit(fit, n, cfg);
    // Two trunks whose bark nearly touches make one cluster: when one circle explains it poorly, two may.
    if (cfg.method == TrunkMethod::kCircle && isPoorSingleFit(p2, fit, rejection, cfg))
    {
      const TrunkPairFit pair = fitTrunkPair(p2, fit, cfg);
      if (pair.ok)
      {
        ++st->split_clusters;
        for (int k = 0; k < 2; ++k)
        {
          TrunkCandidate part;
          std::vector<Eigen::Vector2d> part2;
          part.z_lo = std::numeric_limits<double>::infinity();
          part.z_hi = -std::numeric_limits<double>::infinity();
          for (int i : pair.members[k])
          {
            const Eigen::Vector3d& q = c.points[static_cast<std::size_t>(i)];
            part.points.push_back(q);
            part2.push_back(p2[static_cast<std::size_t>(i)]);
            part.z_lo = std::min(part.z_lo, q.z());
            part.z_hi = std::max(part.z_hi, q.z());
          }
          if (part.z_hi - part.z_lo < cfg.min_vertical_extent || !isUpright(part, part2, cfg))
            ++st->rejected_shape;
          else
            out.push_back(toTrunkObservation(pair.fits[k], static_cast<int>(part2.size()), part.zMid()));
        }
        continue;
      }
    }
    if (rejection != TrunkRejection::kNone)
    {
      countRejection(rejection, st);
      continue;
    }
    if (!isUpright(c, p2, cfg))
    {
      ++st->rejected_shape;
      continue;
    }
    out.push_back(toTrunkObservation(fit, n, c.zMid()));
  }
  timer.lap(&st->ms_fit);
  st->trunks = static_cast<int>(out.size());
  return out;
}

std::vector<TrunkObservation> TrunkDetector::detectScan(const PlanarScan& scan, TrunkDetectorStats* stats)
{
  TrunkDetectorStats local_stats;
  TrunkDetectorStats* st = stats ? stats : &local_stats;
  *st = TrunkDetectorStats();
  const TrunkDetectorConfig& cfg = config_;
  std::vector<TrunkObservation> out;
  st->input_points = static_cast<int>(scan.ranges.size());

  const std::vector<ScanArc> arcs =
      splitScanIntoArcs(scan, cfg.cluster_tolerance, cfg.range_offset, &st->finite_points);
  st->clusters = static_cast<int>(arcs.size());
  st->band_points = st->finite_points;

  const double beam_spacing = std::abs(scan.angle_increment);
  // The checks every fit of an arc passes last: the fit's own rejections, then the arc it subtends (a straight wall
  // segment fits a huge circle or the prior, and its arc does not bulge towards the sensor).
  const auto accept = [&](const TrunkFit& fit, int n) {
    const TrunkRejection rejection = checkTrunkFit(fit, n, cfg);
    if (rejection != TrunkRejection::kNone)
      countRejection(rejection, st);
    else if (fit.method != TrunkMethod::kCentroid && fit.arc_angle > cfg.max_arc_angle)
      ++st->rejected_shape;
    else
      out.push_back(toTrunkObservation(fit, n, 0.0));
  };
  for (const ScanArc& arc : arcs)
  {
    // A far trunk gives an arc of one or two beams: too few to fit a circle, so the radius prior places its centre,
    // and only an isolated, convex arc no wider than a trunk is taken for one (walls, cars and bushes break into
    // short arcs too).
    const int n = static_cast<int>(arc.points.size());
    if (n < cfg.scan_min_beams || n > cfg.max_points)
    {
      ++st->rejected_size;
      continue;
    }
    // A nearer object hides part of the arc: its silhouette does not end where the arc ends on that side, so the
    // centre is fitted to the visible piece with the radius prior (fitPartialArc keeps it only when the points
    // are consistent with a trunk's visible side). It must still be no wider than a trunk and bulge towards the
    // sensor. When it has too few points or is too narrow to show its curvature (kArc), the radius prior and the
    // one silhouette edge place the centre: then one side must be free and stand in front of its background (as
    // both sides of a short arc must), and the fit must pin the centre to within half the prior radius (one
    // standard deviation along its worst axis), which a few far beams beside an occluder do not.
    const bool hidden_first = isArcSideOccluded(scan, arc, ArcSide::kFirst, cfg.cluster_tolerance);
    const bool hidden_last = isArcSideOccluded(scan, arc, ArcSide::kLast, cfg.cluster_tolerance);
    if (hidden_first || hidden_last)
    {
      if (cfg.method != TrunkMethod::kCircle || !isTrunkShapedArc(arc.points, cfg))
      {
        ++st->rejected_shape;
        continue;
      }
      // On a side not hidden the arc ends at the trunk's silhouette, between its last beam and the next
      // informative one (which passes beside the trunk).
      std::vector<SilhouetteEdge> edges;
      for (const ArcSide side : { ArcSide::kFirst, ArcSide::kLast })
      {
        if (side == ArcSide::kFirst ? hidden_first : hidden_last)
          continue;
        const int end = side == ArcSide::kFirst ? arc.first_beam : arc.last_beam;
        double end_range = 0.0;
        const int beam = firstInformativeBeamBeside(scan, arc, side, &end_range);
        if (beam < 0)
          continue;  // the field of view ends: the trunk may go on beyond it
        const double a = scan.angle_min + scan.angle_increment * 0.5 * static_cast<double>(end + beam);
        SilhouetteEdge edge;
        edge.direction = Eigen::Vector2d(std::cos(a), std::sin(a));
        edge.spacing = std::abs(scan.angle_increment) * static_cast<double>(std::abs(beam - end));
        edges.push_back(edge);
      }
      const TrunkFit fit = fitPartialArc(arc.points, edges, cfg);
      if (fit.ok && fit.method == TrunkMethod::kArc &&
          ((hidden_first && hidden_last) ||
           Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(fit.covariance.topLeftCorner<2, 2>()).eigenvalues()(1) >
               std::pow(0.5 * cfg.arc_radius_prior, 2) ||
           (!hidden_first && !isArcSideIsolated(scan, arc, ArcSide::kFirst, cfg.scan_min_jump, cfg.range_offset)) ||
           (!hidden_last && !isArcSideIsolated(scan, arc, ArcSide::kLast, cfg.scan_min_jump, cfg.range_offset))))
      {
        ++st->rejected_clutter;
        continue;
      }
      accept(fit, n);
      continue;
    }
    const bool short_arc = n < cfg.min_fit_points;
    TrunkFit fit = short_arc && cfg.method == TrunkMethod::kCircle ? fitShortArc(arc.points, beam_spacing, cfg) :
                                                                     fitTrunk(arc.points, cfg);
    // Two trunks whose bark nearly touches, side by side, make one arc: when one circle explains it poorly, two may.
    if (!short_arc && cfg.method == TrunkMethod::kCircle &&
        isPoorSingleFit(arc.points, fit, checkTrunkFit(fit, n, cfg), cfg))
    {
      const TrunkPairFit pair = fitTrunkPair(arc.points, fit, cfg);
      if (pair.ok)
      {
        ++st->split_clusters;
        for (int k = 0; k < 2; ++k)
          accept(pair.fits[k], static_cast<int>(pair.members[k].size()));
        continue;
      }
    }
    if ((short_arc || fit.method == TrunkMethod::kArc) &&
        !(isArcIsolated(scan, arc, cfg.scan_min_jump, cfg.range_offset) && isTrunkShapedArc(arc.points, cfg)))
    {
      ++st->rejected_clutter;
      continue;
    }
    accept(fit, n);
  }
  st->trunks = static_cast<int>(out.size());
  return out;
}

void detectorReach(const TrunkDetectorConfig& config, double cloud_step, double* reach, ReachSource* source,
                   double* step)
{
  *step = NAN;
  if (config.sensor_reach > 0.0)
  {
    *reach = config.sensor_reach;
    *source = ReachSource::kConfigured;
    return;
  }
  *step = config.azimuth_resolution > 0.0 ? config.azimuth_resolution : cloud_step;
  *reach = singleRingReach(config.arc_radius_prior, config.min_points, *step);
  *source = !std::isfinite(*reach) ? ReachSource::kUnknown :
            config.azimuth_resolution > 0.0 ? ReachSource::kResolution : ReachSource::kCloud;
}

std::string reachShortfall(const TrunkDetectorConfig& config, const TrunkDetectorStats& stats)
{
  if (!(stats.reach < config.max_range) || stats.reach_source == ReachSource::kConfigured ||
      stats.reach_source == ReachSource::kUnknown)
    return "";
  char text[480];
  std::snprintf(text, sizeof(text),
                "trunks are looked for up to %.1f m, not max_range %.1f m: the points of a ring lie %.3f deg apart "
                "(%s), and a trunk of radius %.2f m (arc_radius_prior) further away gives fewer than min_points %d "
                "on one ring; set azimuth_resolution to the sensor's, or sensor_reach",
                stats.reach, config.max_range, stats.azimuth_step * 180.0 / M_PI,
                stats.reach_source == ReachSource::kResolution ? "azimuth_resolution, the sensor's" :
                                                                "inferred from the cloud's points",
                config.arc_radius_prior, config.min_points);
  return text;
}

}  // namespace core
}  // namespace rbpf_slam
