#include "reconstruct/light_views.h"

#include <utility>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include "core/capture_file.h"
#include "core/error.h"
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
  // Frames capture.json does not list (a calib of another capture) are left out.
  std::vector<std::pair<const CalibratedFrame*, std::string>> imaged;
  for (const CalibratedFrame* frame : frames) {
    const CaptureFrame* listed = capture.Find(frame->name);
    if (listed != nullptr && !listed->image.empty()) imaged.emplace_back(frame, listed->image);
  }
  if (imaged.size() < frames.size()) {
    spdlog::warn("reconstruct: {} of {} registered phone L frames have no image in capture.json; left out",
                 frames.size() - imaged.size(), frames.size());
  }
  result.cameras.resize(imaged.size());
  result.grays.resize(imaged.size());
  tbb::parallel_for(size_t(0), imaged.size(), [&](size_t i) {
    const cv::Mat gray = ReadGrayFrame(workspace, imaged[i].second, distorted, "phone L's calibrated lens");
    cv::remap(gray, result.grays[i], map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    result.cameras[i] = Camera(pinhole, imaged[i].first->cam_from_world);
  });
  return result;
}

}  // namespace relit::reconstruct
