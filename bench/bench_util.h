// Small helpers shared by the benchmarks: process CPU time, the machine's
// load average and peak resident memory (Linux /proc).
#pragma once

#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <string>

namespace relit::bench {

// Wall-clock seconds since `start`.
inline double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// CPU time of the whole process (all threads), seconds. On a shared machine
// it is less sensitive than wall time to other processes competing for cores.
inline double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// "1.23 0.98 0.77" from /proc/loadavg: timings on a busy machine are not comparable.
inline std::string LoadAverage() {
  std::ifstream file("/proc/loadavg");
  double a = 0, b = 0, c = 0;
  if (!(file >> a >> b >> c)) return "unknown";
  char text[64];
  std::snprintf(text, sizeof(text), "%.2f %.2f %.2f", a, b, c);
  return text;
}

// Today's local date, YYYY-MM-DD.
inline std::string Today() {
  char date[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof(date), "%Y-%m-%d", std::localtime(&now));
  return date;
}

// A "Vm*:  1234 kB" field of /proc/self/status in MiB (VmRSS = resident now,
// VmHWM = peak resident since start or the last ResetPeakRss); -1 if absent.
inline double ProcStatusMiB(const std::string& field) {
  std::ifstream file("/proc/self/status");
  std::string line;
  while (std::getline(file, line)) {
    if (line.rfind(field + ":", 0) == 0) return std::atof(line.c_str() + field.size() + 1) / 1024.0;
  }
  return -1;
}

// Resets VmHWM to the current VmRSS (Linux >= 4.0: "5" > /proc/self/clear_refs),
// so the next VmHWM is the peak of what runs in between. False if refused.
inline bool ResetPeakRss() {
  std::ofstream file("/proc/self/clear_refs");
  file << "5";
  file.flush();
  return static_cast<bool>(file);
}

}  // namespace relit::bench
