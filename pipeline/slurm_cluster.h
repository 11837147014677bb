// Test support: a single-node Slurm cluster on this machine (Debian's munge,
// slurmctld, slurmd from slurm-wlm), started by a test and stopped when the
// object goes away. Everything (keys, state, logs, sockets) lives in a folder
// of the test; ports are chosen per process. Needs root (slurmd starts jobs
// as their user); without it, or without the packages, Start() says why.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

namespace relit::pipeline::testing {

class SlurmCluster {
 public:
  // Starts the daemons with their files in `dir` and waits (up to ~60 s)
  // until the node accepts jobs; sets SLURM_CONF for this process (and so
  // for sbatch/squeue run from it). Returns null with *why_not set when the
  // machine cannot run it.
  static std::unique_ptr<SlurmCluster> Start(const std::filesystem::path& dir, std::string* why_not);
  ~SlurmCluster();

  const std::filesystem::path& dir() const { return dir_; }
  // The daemons' logs, for failure messages.
  std::string Logs() const;

 private:
  explicit SlurmCluster(std::filesystem::path dir) : dir_(std::move(dir)) {}
  void Stop();
  std::filesystem::path dir_;
};

}  // namespace relit::pipeline::testing
