// Small helpers shared by the benchmarks: the machine's load average and
// peak resident memory (Linux /proc). Wall and CPU time: SecondsSince and
// ProcessCpuSeconds in core/run_record.h.
#pragma once

#include <cstdio>
#include <ctime>
#include <fstream>
#include <string>

#include "core/run_record.h"

namespace relit::bench {

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
