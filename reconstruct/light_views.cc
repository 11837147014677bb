#include "reconstruct/light_views.h"

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include "core/capture_file.h"
#include "core/error.h"
#include "core/image.h"
#include "reconstruct/proxy_source.h"

namespace relit::reconstruct {

LightViews LoadLightViews(const std::filesystem::path& workspace, const CamerasFile& cameras, int max_frames) {
  LightViews result;
  const std::vector<const CalibratedFrame*> frames = Subsample(cameras.FramesOf("light"), max_frames);
  if (frames.empty()) return result;
  const auto lens = cameras.devices.find("light");
  RELIT_REQUIRE(lens != cameras.devices.end(), "reconstruct: calib/cameras.json has phone L frames but no device "
                "\"light\" lens; rerun relit-calib");
  const std::string capture_path = CaptureFilePath(workspace.string());
  if (!std::filesystem::exists(capture_path)) {
    spdlog::info("reconstruct: no {}: phone L's frames have no images to vote with", capture_path);
    return result;
  }
  const CaptureFile capture = ReadCaptureFile(capture_path);
  const Intrinsics& distorted = lens->second;
  const Intrinsics pinhole = distorted.WithoutDistortion();
  cv::Mat map_x, map_y;
  UndistortionMaps(distorted, pinhole, &map_x, &map_y);
  std::vector<const CaptureFrame*> images(frames.size(), nullptr);
  for (size_t i = 0; i < frames.size(); ++i) images[i] = capture.Find(frames[i]->name);
  result.cameras.resize(frames.size());
  result.grays.resize(frames.size());
  tbb::parallel_for(size_t(0), frames.size(), [&](size_t i) {
    if (images[i] == nullptr || images[i]->image.empty()) return;
    const std::string path = (workspace / images[i]->image).string();
    const Image image = ReadImage(path);
    RELIT_REQUIRE(image.width() == distorted.width && image.height() == distorted.height && image.channels() >= 3,
                  "reconstruct: ", path, " is ", image.width(), "x", image.height(), "x", image.channels(),
                  ", phone L's calibrated lens is ", distorted.width, "x", distorted.height,
                  " RGB; rerun relit-calib on this capture");
    cv::Mat rgb = image.SelectChannels(std::vector<int>{0, 1, 2}).ToMat(), gray8, gray;
    cv::cvtColor(rgb, gray, cv::COLOR_RGB2GRAY);
    gray.convertTo(gray8, CV_8U, 255.0);
    cv::remap(gray8, result.grays[i], map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    result.cameras[i] = Camera(pinhole, frames[i]->cam_from_world);
  });
  // Frames capture.json does not list (a calib from another capture) are left out.
  size_t kept = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (result.grays[i].empty()) continue;
    result.cameras[kept] = result.cameras[i];
    result.grays[kept] = result.grays[i];
    ++kept;
  }
  if (kept < frames.size()) {
    spdlog::warn("reconstruct: {} of {} registered phone L frames have no image in capture.json; left out",
                 frames.size() - kept, frames.size());
  }
  result.cameras.resize(kept);
  result.grays.resize(kept);
  return result;
}

}  // namespace relit::reconstruct
