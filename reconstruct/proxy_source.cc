#include "reconstruct/proxy_source.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/image.h"
#include "core/median.h"
#include "core/progress.h"
#include "reconstruct/depth_cache.h"
#include "reconstruct/depth_fusion.h"
#include "reconstruct/depth_hull.h"
#include "reconstruct/photo_refine.h"
#include "reconstruct/point_surface.h"
#include "reconstruct/stereo_depth.h"

namespace relit::reconstruct {
namespace {

namespace fs = std::filesystem;

std::string FrameList(const std::vector<std::string>& names) {
  std::string text;
  for (size_t i = 0; i < names.size() && i < 8; ++i) text += (i ? ", " : "") + names[i];
  if (names.size() > 8) text += " and " + std::to_string(names.size() - 8) + " more";
  return text;
}

struct DensePoints {
  std::vector<FusedPoint> points;
  std::vector<std::string> frames_without_points;
  double pixel_footprint_m = 0;  // median over frames, at the crop centre
  // Per frame, the depths other frames confirm (FuseDepthMaps), when asked
  // for: the hull carves with them and the refinement after cleanup trusts them.
  std::vector<cv::Mat> consistent_depths;
  std::vector<cv::Mat> grays;  // the frames the depth maps are of (CV_8U)
};

// Depth maps of every frame, then multi-view consistency and fusion.
DensePoints DenseDepthPoints(const fs::path& workspace, const CamerasFile& cameras,
                             const std::vector<const CalibratedFrame*>& frames, const CropRegion& crop,
                             const ProxyOptions& options, bool flash_lit, bool want_consistent_depths,
                             RunRecord* record, nlohmann::json* report) {
  const size_t n = frames.size();
  std::vector<DepthView> views(n);
  std::vector<Camera> camera_list(n);
  {
    auto timer = record->Time("proxy_load_frames");
    tbb::parallel_for(size_t(0), n, [&](size_t i) {
      const CalibratedFrame& f = *frames[i];
      views[i].name = f.name;
      views[i].camera = cameras.ViewCamera(f);
      views[i].gray = ReadGrayFrame(workspace, f.image_8bit, views[i].camera.intrinsics(), "the undistorted camera");
      camera_list[i] = views[i].camera;
    });
  }
  const Eigen::Vector3d centre(crop.centre_xy.x(), crop.centre_xy.y(), 0.0);
  SceneBox box;
  box.min = Eigen::Vector3d(centre.x() - crop.radius_m, centre.y() - crop.radius_m, options.min_height_m);
  box.max = Eigen::Vector3d(centre.x() + crop.radius_m, centre.y() + crop.radius_m, 2.0 * crop.radius_m);
  const std::vector<std::vector<int>> neighbours = SelectStereoNeighbours(camera_list, centre, options);
  std::vector<cv::Mat> depths(n);
  std::vector<std::string> no_neighbour;
  for (size_t i = 0; i < n; ++i) {
    if (neighbours[i].empty()) no_neighbour.push_back(frames[i]->name);
  }
  if (!no_neighbour.empty()) {
    spdlog::warn("{} frames have no stereo neighbour within {}-{} deg: {}", no_neighbour.size(),
                 options.min_baseline_deg, options.max_baseline_deg, FrameList(no_neighbour));
  }
  const DepthMapCache cache(workspace / "reconstruct_cache" / "depth_maps");
  std::atomic<int> cached{0};
  std::atomic<int64_t> textureless{0}, near_edges{0};
  const double min_texture = flash_lit ? options.flash_min_texture : 0.0;
  {
    auto timer = record->Time("proxy_depth_maps");
    Progress progress("depth maps", static_cast<int64_t>(n));
    tbb::parallel_for(size_t(0), n, [&](size_t i) {
      std::vector<cv::Mat> pairs;
      for (int j : neighbours[i]) {
        const fs::path entry = cache.Entry(views[i], views[j], workspace / frames[i]->image_8bit,
                                           workspace / frames[j]->image_8bit, box, options);
        cv::Mat pair = cache.Load(entry);
        if (!pair.empty()) {
          ++cached;
        } else {
          pair = PairDepthMap(views[i], views[j], box, options);
          cache.Store(entry, pair);
        }
        pairs.push_back(pair);
      }
      depths[i] = pairs.empty() ? cv::Mat(views[i].gray.size(), CV_32F, cv::Scalar(0))
                                : CombinePairDepthMaps(pairs, options);
      textureless += DropTexturelessDepths(views[i].gray, min_texture, options.block_size_px, &depths[i]);
      near_edges += DropDepthsNearFartherEdges(options.edge_margin_px, 2.0 * options.depth_tolerance, &depths[i]);
      progress.Advance();
    });
  }
  (*report)["pair_depth_maps_from_cache"] = cached.load();
  (*report)["textureless_depth_px"] = textureless.load();
  (*report)["edge_depth_px"] = near_edges.load();
  if (min_texture > 0) {
    spdlog::info("dense: dropped {} depth pixels of the flash-lit frames with a block grey std below {} (no texture "
                 "to match)",
                 textureless.load(), min_texture);
  }
  if (options.edge_margin_px > 0) {
    spdlog::info("dense: dropped {} depth pixels within {} px of a farther depth (fattened edges)", near_edges.load(),
                 options.edge_margin_px);
  }
  if (cached > 0) spdlog::info("dense: {} pair depth maps from the cache", cached.load());
  // Dense method only: the advancing front of the sparse method over these
  // points (no COLMAP model) came out worse and unstable on refined points
  // (tiny test 2.5-6.2 % of the diagonal, against 1.5-2.2 % without).
  if (options.photo.enabled && options.method == "dense") {
    auto timer = record->Time("proxy_photo_refine");
    Progress progress("photometric refinement", static_cast<int64_t>(n));
    PhotoRefineStats photo;
    depths = RefineDepthMapsPhotometric(views, depths, centre, box, options, &photo, [&] { progress.Advance(); });
    (*report)["photo_refine"] = photo.ToJson();
    spdlog::info("dense: photometric refinement moved {} depth pixels by {:.2f} mm on average, dropped {}, kept {} "
                 "flat and {} unseen ones",
                 photo.refined_px, 1e3 * photo.mean_shift_m, photo.dropped_px, photo.flat_px, photo.unseen_px);
  }
  DensePoints result;
  std::vector<FrameFusionStats> stats;
  {
    auto timer = record->Time("proxy_consistency");
    Progress progress("consistency", static_cast<int64_t>(n));
    result.points = FuseDepthMaps(camera_list, depths, crop, options, &stats,
                                  want_consistent_depths ? &result.consistent_depths : nullptr,
                                  [&] { progress.Advance(); });
  }
  nlohmann::json frame_reports = nlohmann::json::array();
  for (size_t i = 0; i < n; ++i) {
    if (stats[i].consistent_px == 0) result.frames_without_points.push_back(frames[i]->name);
    nlohmann::json fr = stats[i].ToJson();
    fr["frame"] = frames[i]->name;
    fr["neighbours"] = nlohmann::json::array();
    for (int j : neighbours[i]) fr["neighbours"].push_back(frames[j]->name);
    frame_reports.push_back(fr);
  }
  result.pixel_footprint_m = MedianPixelFootprint(camera_list, centre);
  if (want_consistent_depths) {
    for (DepthView& view : views) result.grays.push_back(std::move(view.gray));
  }
  (*report)["frames"] = frame_reports;
  (*report)["fused_points"] = result.points.size();
  spdlog::info("dense: {} consistent depth points from {} frames ({} without any)", result.points.size(), n,
               result.frames_without_points.size());
  return result;
}

// Sparse input points: COLMAP's model when calib wrote one, each pointing
// to the cameras that see it (calib exports no tracks: those whose image it
// projects into), else the dense depth points.
std::vector<FusedPoint> SparsePoints(const fs::path& workspace, const std::vector<Camera>& cameras,
                                     const CropRegion& crop, const ProxyOptions& options,
                                     const std::vector<FusedPoint>* depth_points, nlohmann::json* report) {
  const fs::path model = workspace / "calib" / "model" / "points3D.txt";
  std::vector<FusedPoint> points;
  if (fs::exists(model)) {
    for (const Eigen::Vector3d& p : ReadColmapPoints(model.string())) {
      if (!InCrop(p, crop, options.min_height_m)) continue;
      Eigen::Vector3d direction = Eigen::Vector3d::Zero();
      for (const Camera& camera : cameras) {
        Eigen::Vector2d pixel;
        if (camera.Project(p, &pixel) && pixel.x() >= 0 && pixel.y() >= 0 &&
            pixel.x() < camera.intrinsics().width && pixel.y() < camera.intrinsics().height) {
          direction += (camera.Center() - p).normalized();
        }
      }
      if (direction.norm() > 0) points.push_back({p, direction.normalized()});
    }
    (*report)["sparse_source"] = model.string();
    spdlog::info("sparse: {} COLMAP points in the crop region ({})", points.size(), model.string());
  }
  if (points.size() < 100 && depth_points) {
    points = *depth_points;
    (*report)["sparse_source"] = "depth points";
  }
  return points;
}

// Samples of the depth-map hull's surface where no point of *points is
// near (depth_hull.h), appended to *points and written to hull_points.ply.
void AddHullPoints(const std::vector<Camera>& cameras, const std::vector<cv::Mat>& consistent_depths,
                   const CropRegion& crop, const ProxyOptions& options, double spacing, const fs::path& work_dir,
                   RunRecord* record, nlohmann::json* report, std::vector<OrientedPoint>* points) {
  auto timer = record->Time("proxy_depth_hull");
  const double voxel = options.hull.voxel_m > 0 ? options.hull.voxel_m : spacing;
  const VoxelHull hull = CarveDepthHull(cameras, consistent_depths, *points, crop, options.hull, options.min_height_m, voxel);
  if (hull.open_border_fraction > options.hull.max_open_border) {
    // Not carved all around (a background without depth, too few views):
    // the hull's surface would be the grid's, not the object's.
    (*report)["depth_hull"] = {{"skipped", true}, {"open_border_fraction", hull.open_border_fraction}};
    spdlog::warn("depth hull: skipped, the depth maps leave {:.1f}% of the grid's sides and top uncarved "
                 "(proxy.hull.max_open_border {:.1f}%); the background behind the object has too little depth "
                 "(or too few frames see past it)",
                 100 * hull.open_border_fraction, 100 * options.hull.max_open_border);
    return;
  }
  DepthHullReport hull_report;
  hull_report.voxels = hull.size;
  hull_report.voxel_m = hull.voxel_m;
  hull_report.components = hull.components;
  hull_report.open_border_fraction = hull.open_border_fraction;
  hull_report.occupied_voxels = static_cast<int>(std::count(hull.occupied.begin(), hull.occupied.end(), 1));
  const std::vector<OrientedPoint> added =
      HullSurfacePoints(hull, *points, options.hull.point_gap * spacing, &hull_report.surface_points);
  hull_report.added_points = static_cast<int>(added.size());
  WriteOrientedPly((work_dir / "hull_points.ply").string(), added);
  points->insert(points->end(), added.begin(), added.end());
  hull_report.seconds = timer.Stop();
  (*report)["depth_hull"] = hull_report.ToJson();
  spdlog::info("depth hull: {}x{}x{} voxels of {:.2f} mm, {} occupied; {} of its {} surface samples added "
               "where no point is within {:.1f} mm",
               hull.size.x(), hull.size.y(), hull.size.z(), 1e3 * hull.voxel_m, hull_report.occupied_voxels,
               hull_report.added_points, hull_report.surface_points, 1e3 * options.hull.point_gap * spacing);
}

}  // namespace

cv::Mat ReadGrayFrame(const fs::path& workspace, const std::string& image_path, const Intrinsics& camera,
                      const std::string& camera_name) {
  const Image image = ReadImage((workspace / image_path).string());
  RELIT_REQUIRE(image.width() == camera.width && image.height() == camera.height && image.channels() >= 3,
                "reconstruct: ", image_path, " is ", image.width(), "x", image.height(), "x", image.channels(), ", ",
                camera_name, " is ", camera.width, "x", camera.height, " RGB; rerun relit-calib on this capture");
  cv::Mat rgb = image.SelectChannels(std::vector<int>{0, 1, 2}).ToMat(), gray, gray8;
  cv::cvtColor(rgb, gray, cv::COLOR_RGB2GRAY);
  gray.convertTo(gray8, CV_8U, 255.0);
  return gray8;
}

std::vector<const CalibratedFrame*> Subsample(const std::vector<const CalibratedFrame*>& frames, int max_frames) {
  if (max_frames <= 0 || static_cast<int>(frames.size()) <= max_frames) return frames;
  std::vector<const CalibratedFrame*> out;
  for (int i = 0; i < max_frames; ++i) out.push_back(frames[static_cast<size_t>(i) * frames.size() / max_frames]);
  return out;
}

std::vector<const CalibratedFrame*> GeometryFrames(const CamerasFile& cameras, std::string* source) {
  for (const char* device : {"geometry", "view"}) {
    std::vector<const CalibratedFrame*> frames;
    for (const CalibratedFrame* f : cameras.FramesOf(device)) {
      if (!f->image_8bit.empty()) frames.push_back(f);
    }
    if (!frames.empty()) {
      *source = device;
      return frames;
    }
  }
  *source = "";
  return {};
}

CropRegion CropFromCameras(const CamerasFile& cameras, const std::vector<const CalibratedFrame*>& frames,
                           const CleanupOptions& options) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const CalibratedFrame* f : frames) {
    const Camera camera = cameras.ViewCamera(*f);
    const Eigen::Vector3d d = camera.ViewDirection();
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
    a += p;
    b += p * camera.Center();
  }
  CropRegion crop;
  const Eigen::Vector3d centre = a.ldlt().solve(b);
  crop.centre_xy = centre.head<2>();
  std::vector<double> widths;
  for (const CalibratedFrame* f : frames) {
    const Camera camera = cameras.ViewCamera(*f);
    widths.push_back((camera.Center() - centre).norm() * camera.intrinsics().width / camera.intrinsics().fx);
  }
  crop.radius_m = options.crop_radius_m > 0 ? options.crop_radius_m
                                            : std::max(0.1, options.crop_radius_scale * 0.25 * Median(std::move(widths)));
  return crop;
}

render::TriangleMesh BuildProxyFromImages(const fs::path& workspace, const CamerasFile& cameras,
                                          const CropRegion& crop, const ProxyOptions& options,
                                          const fs::path& work_dir, RunRecord* record, nlohmann::json* report,
                                          DepthEvidence* evidence) {
  std::string source;
  const std::vector<const CalibratedFrame*> frames = Subsample(GeometryFrames(cameras, &source), options.max_frames);
  RELIT_REQUIRE(frames.size() >= 2, "reconstruct: the ", options.method, " proxy needs at least 2 frames with ",
                "undistorted images in calib/cameras.json, found ", frames.size());
  (*report)["input_frames"] = {{"device", source}, {"count", frames.size()}};
  spdlog::info("proxy: {} path on {} {} frames", options.method, frames.size(), source);
  std::unique_ptr<tbb::global_control> threads;
  if (options.threads > 0) {
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, options.threads);
  }
  fs::create_directories(work_dir);
  std::vector<Camera> camera_list;
  for (const CalibratedFrame* f : frames) camera_list.push_back(cameras.ViewCamera(*f));

  // The sparse method with a COLMAP model needs no depth maps.
  const bool have_model = fs::exists(workspace / "calib" / "model" / "points3D.txt");
  DensePoints dense;
  if (options.method == "dense" || !have_model) {
    dense = DenseDepthPoints(workspace, cameras, frames, crop, options, source == "view",
                             evidence || options.hull.enabled, record, report);
  }
  const double spacing = options.point_spacing_m > 0 ? options.point_spacing_m : 1.5 * dense.pixel_footprint_m;
  const std::string advice =
      "check that the frames are sharp, textured and lit and that calib's poses are right (calib_report.json), "
      "or lower proxy.min_consistent_views or proxy.min_consistent_fraction, or pass a mesh with --mesh";
  std::string method = options.method;
  if (method == "dense" && static_cast<int>(dense.points.size()) < options.min_points) {
    RELIT_REQUIRE(options.sparse_fallback, "reconstruct: only ", dense.points.size(),
                  " depth points survived the consistency check (proxy.min_points ", options.min_points,
                  "); frames without any: ", FrameList(dense.frames_without_points), "; ", advice);
    spdlog::warn("dense: only {} depth points (proxy.min_points {}); falling back to the sparse surface",
                 dense.points.size(), options.min_points);
    method = "sparse";
  }
  (*report)["method"] = method;
  std::vector<cv::Mat> consistent = std::move(dense.consistent_depths);
  render::TriangleMesh mesh;
  if (method == "dense") {
    std::vector<OrientedPoint> oriented;
    {
      auto timer = record->Time("proxy_normals");
      oriented = OrientedPointCloud(dense.points, spacing, options.normal_neighbours, 3.0 * spacing,
                                    options.min_cluster_fraction);
    }
    (*report)["oriented_points"] = oriented.size();
    (*report)["point_spacing_m"] = spacing;
    if (options.hull.enabled) {
      AddHullPoints(camera_list, consistent, crop, options, spacing, work_dir, record, report, &oriented);
    }
    const std::string points_ply = (work_dir / "fused_points.ply").string();
    WriteOrientedPly(points_ply, oriented);
    auto timer = record->Time("proxy_poisson");
    mesh = PoissonSurface(points_ply, (work_dir / "poisson.ply").string(), (work_dir / "poisson_mesher.log").string(),
                          options);
  } else {
    const std::vector<FusedPoint> input =
        SparsePoints(workspace, camera_list, crop, options, have_model && options.method == "sparse" ? nullptr
                                                                                                      : &dense.points,
                     report);
    std::vector<OrientedPoint> cleaned;
    {
      auto timer = record->Time("proxy_normals");
      // Sparse COLMAP points are far apart: outliers are judged by their own spacing.
      cleaned = OrientedPointCloud(input, spacing > 0 ? spacing : 1e-4, options.normal_neighbours, 0.0,
                                   options.min_cluster_fraction);
    }
    // Over depth points the hull closes what the stereo missed here too
    // (the advancing front otherwise breaks up around those gaps).
    if (options.hull.enabled && !consistent.empty() && cleaned.size() >= 10) {
      AddHullPoints(camera_list, consistent, crop, options, spacing, work_dir, record, report, &cleaned);
    }
    (*report)["sparse_points"] = cleaned.size();
    RELIT_REQUIRE(cleaned.size() >= 100, "reconstruct: too few points for a surface (", cleaned.size(),
                  " after outlier removal, sparse method)",
                  dense.frames_without_points.empty() ? std::string()
                                                      : "; frames without depth points: " +
                                                            FrameList(dense.frames_without_points),
                  "; ", advice);
    std::vector<Eigen::Vector3d> positions;
    for (const OrientedPoint& p : cleaned) positions.push_back(p.position_m);
    auto timer = record->Time("proxy_advancing_front");
    mesh = AdvancingFrontSurface(positions, options);
    RELIT_REQUIRE(!mesh.triangles.empty(), "reconstruct: the advancing-front surface over ", positions.size(),
                  " points is empty; ", advice);
  }
  if (evidence && !consistent.empty()) {
    *evidence = DepthEvidence{};
    for (const CalibratedFrame* f : frames) evidence->names.push_back(f->name);
    evidence->cameras = camera_list;
    evidence->depths = std::move(consistent);
    evidence->grays = std::move(dense.grays);
  }
  (*report)["raw_faces"] = mesh.triangles.size();
  spdlog::info("proxy: {} surface with {} faces", method, mesh.triangles.size());
  return mesh;
}

}  // namespace relit::reconstruct
