#include "bench/cycles.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "core/error.h"
#include "core/shell.h"

namespace relit::bench {

namespace {

// Single-quotes a string for /bin/sh.
std::string Number(double v) {
  // Fixed notation: argparse would take "-4e-08" for an option name.
  std::ostringstream stream;
  stream << std::fixed << std::setprecision(9) << v;
  std::string s = stream.str();
  while (s.size() > 1 && s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

std::string Numbers(const Eigen::Vector3d& v) {
  return Number(v.x()) + " " + Number(v.y()) + " " + Number(v.z());
}

// Runs a shell command, returning its combined output; *status gets the exit code.
std::string Capture(const std::string& command, int* status) {
  std::string output;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) {
    *status = -1;
    return output;
  }
  char buffer[4096];
  while (fgets(buffer, sizeof(buffer), pipe) != nullptr) output += buffer;
  const int raw = pclose(pipe);
  *status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return output;
}

std::string Field(const std::string& line, const std::string& name) {
  const std::string key = " " + name + "=";
  const size_t start = line.find(key);
  if (start == std::string::npos) return "";
  const size_t begin = start + key.size();
  const size_t end = name == "output" ? line.size() : line.find(' ', begin);
  return line.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
}

float Luminance(const Image& image, int x, int y) {
  return 0.2126f * image.at(x, y, 0) + 0.7152f * image.at(x, y, 1) + 0.0722f * image.at(x, y, 2);
}

}  // namespace

const CyclesRender* CyclesResult::Find(const std::string& material) const {
  for (const CyclesRender& render : renders) {
    if (render.material == material) return &render;
  }
  return nullptr;
}

std::string FindExecutable(const std::string& name) {
  if (name.find('/') != std::string::npos) return access(name.c_str(), X_OK) == 0 ? name : "";
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const std::string candidate = dir + "/" + name;
    if (access(candidate.c_str(), X_OK) == 0 && !std::filesystem::is_directory(candidate)) return candidate;
  }
  return "";
}

namespace {
std::vector<std::string> Tokens(const std::vector<CowMaterial>& materials) {
  std::vector<std::string> tokens;
  for (CowMaterial m : materials) tokens.push_back(MaterialName(m));
  return tokens;
}
}  // namespace

std::string DiffuseToken(const std::string& name, double albedo) { return name + "=diffuse:" + Number(albedo); }

std::string GlossyToken(const std::string& name, double albedo, double ggx_alpha) {
  return name + "=glossy:" + Number(albedo) + ":" + Number(ggx_alpha);
}

std::string CyclesCommand(const BenchSceneSpec& spec, const CyclesOptions& options,
                          const std::vector<CowMaterial>& materials) {
  return CyclesCommand(spec, options, Tokens(materials));
}

CyclesResult RunCycles(const BenchSceneSpec& spec, const CyclesOptions& options,
                       const std::vector<CowMaterial>& materials) {
  return RunCycles(spec, options, Tokens(materials));
}

std::string CyclesCommand(const BenchSceneSpec& spec, const CyclesOptions& options,
                          const std::vector<std::string>& materials) {
  std::string names;
  for (const std::string& m : materials) names += std::string(names.empty() ? "" : ",") + m;
  std::string matrix;
  const Eigen::Matrix4f m = spec.cow_world_from_object.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) matrix += (matrix.empty() ? "" : " ") + Number(m(r, c));
  }
  std::ostringstream cmd;
  cmd << ShellQuote(options.blender) << " -b --factory-startup -noaudio --python-exit-code 1 --python "
      << ShellQuote(options.script) << " --"
      << " --mesh " << ShellQuote(spec.mesh_path) << " --output-dir " << ShellQuote(options.output_dir)
      << " --materials " << ShellQuote(names) << " --width " << spec.width << " --height " << spec.height
      << " --spp " << options.samples_per_pixel << " --max-bounces " << options.max_depth - 1
      << " --threads " << options.threads << " --repeats " << options.repeats
      << " --seed " << options.seed << " --object-matrix " << matrix
      << " --camera-eye " << Numbers(spec.camera_eye) << " --camera-target " << Numbers(spec.camera_target)
      << " --hfov-deg " << Number(spec.horizontal_fov_rad * 180.0 / M_PI)
      << " --light-position " << Numbers(spec.light_position.cast<double>())
      << " --light-intensity " << Number(spec.light_intensity)
      << " --ground-half-size " << Number(spec.ground_half_size)
      << " --ground-albedo " << Number(spec.ground_albedo)
      << " --lambert-albedo " << Number(spec.lambert_albedo) << " --ggx-albedo " << Number(spec.ggx_albedo)
      << " --ggx-alpha " << Number(spec.ggx_alpha);
  return cmd.str();
}

CyclesResult RunCycles(const BenchSceneSpec& spec, const CyclesOptions& options,
                       const std::vector<std::string>& materials) {
  CyclesResult result;
  const std::string blender = FindExecutable(options.blender);
  if (blender.empty()) {
    result.status = "not installed (run tools/install-bench-deps)";
    return result;
  }
  int status = 0;
  std::string version = Capture(ShellQuote(blender) + " --version", &status);
  version = version.substr(0, version.find('\n'));
  std::filesystem::create_directories(options.output_dir);
  const std::string log_path = options.output_dir + "/cycles.log";
  CyclesOptions resolved = options;
  resolved.blender = blender;
  const std::string output = Capture(CyclesCommand(spec, resolved, materials), &status);
  std::ofstream(log_path) << output;

  std::istringstream lines(output);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("RELIT_CYCLES ", 0) != 0) continue;
    line = " " + line.substr(13);
    CyclesRender render;
    render.material = Field(line, "material");
    render.seconds = std::atof(Field(line, "seconds").c_str());
    render.cpu_seconds = std::atof(Field(line, "cpu_seconds").c_str());
    render.exr_path = Field(line, "output");
    result.renders.push_back(render);
  }
  if (status != 0 || result.renders.size() != materials.size()) {
    result.status = "failed (exit code " + std::to_string(status) + "; see " + log_path + ")";
    return result;
  }
  result.ran = true;
  result.status = version + ", CPU, " + std::to_string(options.threads) + " threads";
  return result;
}

ImageComparison CompareOnObject(const Image& a, const Image& b, const Image& object_ids, int object_id) {
  RELIT_REQUIRE(a.width() == b.width() && a.height() == b.height() && a.width() == object_ids.width() &&
                    a.height() == object_ids.height(),
                "cannot compare images of different sizes: ", a.width(), "x", a.height(), " vs ", b.width(),
                "x", b.height());
  RELIT_REQUIRE(a.channels() >= 3 && b.channels() >= 3, "image comparison needs RGB images");
  ImageComparison result;
  double sum_relative = 0, sum_a = 0, sum_b = 0;
  const float id = static_cast<float>(object_id);
  for (int y = 1; y + 1 < a.height(); ++y) {
    for (int x = 1; x + 1 < a.width(); ++x) {
      bool interior = true;
      for (int dy = -1; dy <= 1 && interior; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) interior = interior && object_ids.at(x + dx, y + dy, 0) == id;
      }
      if (!interior) continue;
      const double la = Luminance(a, x, y), lb = Luminance(b, x, y);
      sum_a += la;
      sum_b += lb;
      if (la + lb > 0) sum_relative += 2.0 * std::abs(la - lb) / (la + lb);
      ++result.pixels;
    }
  }
  if (result.pixels > 0) result.mean_relative_difference = sum_relative / result.pixels;
  result.mean_ratio = sum_b > 0 ? sum_a / sum_b : 0;
  return result;
}

}  // namespace relit::bench
