// A JSON record of what a stage ran with, written next to its outputs, so a
// result can be traced back to the options, inputs and build that made it.
//
//   RunRecord record("relight");
//   record.SetCommandLine(argc, argv);
//   record.SetOptions(options.ToJson());
//   record.AddInput("cameras", cameras_path);
//   {
//     auto timer = record.Time("render");
//     ...
//   }
//   record.Set("frames", frame_count);
//   record.Write(out_dir + "/run.json");
//
// The file has schema relit.run/1:
//   {"schema", "tool", "version", "start_time_utc", "hostname",
//    "command_line", "options", "inputs", "timings_s", "total_s", ...Set()}
#pragma once

#include <chrono>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>

namespace relit {

// The project version this library was built from (CMake PROJECT_VERSION).
const char* RelitVersion();

// Wall-clock seconds since `start` (steady clock).
double SecondsSince(std::chrono::steady_clock::time_point start);

// User + system CPU seconds of this process so far, all threads (getrusage):
// the training budget of train.json (`process_cpu_s`), and on a shared
// machine less sensitive than wall time to other processes.
double ProcessCpuSeconds();

class RunRecord {
 public:
  static constexpr const char* kKind = "run";
  static constexpr int kVersion = 1;

  explicit RunRecord(std::string tool);

  void SetCommandLine(int argc, char** argv);
  void SetOptions(nlohmann::json options);
  // Records an input file by role, e.g. AddInput("mesh", "scan/mesh.ply").
  void AddInput(const std::string& role, const std::string& path);
  // Extra top-level fields (results, counts). The fields listed above are
  // reserved; setting one is a bug.
  void Set(const std::string& key, nlohmann::json value);

  // Measures wall time from Time() until the Scope ends (or Stop()). Times
  // of a step recorded more than once add up. Thread-safe.
  class Scope {
   public:
    Scope(Scope&& other) noexcept;
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;
    Scope& operator=(Scope&&) = delete;
    ~Scope();
    // Ends the measurement early; returns the seconds recorded.
    double Stop();

   private:
    friend class RunRecord;
    Scope(RunRecord* record, std::string step);
    RunRecord* record_;  // null once stopped or moved from
    std::string step_;
    std::chrono::steady_clock::time_point start_;
  };
  Scope Time(std::string step);
  void AddTiming(const std::string& step, double seconds);

  // The record as written (total_s measured now).
  nlohmann::json ToJson() const;
  // Writes ToJson() atomically with schema relit.run/1.
  void Write(const std::string& path) const;

 private:
  const std::string tool_;
  const std::string start_time_utc_;
  const std::chrono::steady_clock::time_point start_;
  mutable std::mutex mutex_;
  nlohmann::json fields_;  // everything except the computed fields
};

// "2024-05-01T12:34:56Z" for the current time.
std::string CurrentTimeIso8601Utc();

}  // namespace relit
