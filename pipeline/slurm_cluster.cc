#include "pipeline/slurm_cluster.h"

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include "core/shell.h"
#include "pipeline/executor.h"
#include "pipeline/test_support.h"

namespace relit::pipeline::testing {

namespace fs = std::filesystem;

namespace {

bool Executable(const std::string& path) { return ::access(path.c_str(), X_OK) == 0; }

pid_t ReadPid(const fs::path& file) {
  std::ifstream in(file);
  pid_t pid = 0;
  in >> pid;
  return pid;
}

}  // namespace

std::unique_ptr<SlurmCluster> SlurmCluster::Start(const fs::path& dir, std::string* why_not) {
  if (::geteuid() != 0) {
    *why_not = "needs root: slurmd starts jobs as their user and munged/slurmctld run as root here";
    return nullptr;
  }
  for (const char* daemon : {"/usr/sbin/munged", "/usr/sbin/slurmctld", "/usr/sbin/slurmd"}) {
    if (!Executable(daemon)) {
      *why_not = std::string(daemon) + " is missing: install munge and slurm-wlm (tools/install-deps)";
      return nullptr;
    }
  }
  std::string out;
  if (RunCapture("command -v sbatch squeue", &out) != 0) {
    *why_not = "sbatch/squeue not on PATH: install slurm-client (slurm-wlm, tools/install-deps)";
    return nullptr;
  }
  char host_buffer[256] = {0};
  ::gethostname(host_buffer, sizeof(host_buffer) - 1);
  const std::string host = host_buffer;

  std::unique_ptr<SlurmCluster> cluster(new SlurmCluster(dir));
  fs::create_directories(dir / "state");
  fs::create_directories(dir / "spool");
  fs::create_directories(dir / "log");
  fs::permissions(dir, fs::perms::owner_all, fs::perm_options::replace);
  {
    // munged refuses keys that others can read.
    std::ofstream key(dir / "munge.key", std::ios::binary);
    std::mt19937_64 random(std::random_device{}());
    for (int i = 0; i < 128; ++i) {
      const uint64_t v = random();
      key.write(reinterpret_cast<const char*>(&v), sizeof(v));
    }
  }
  fs::permissions(dir / "munge.key", fs::perms::owner_read | fs::perms::owner_write,
                  fs::perm_options::replace);
  const std::string d = dir.string();
  const int port = 20000 + static_cast<int>(::getpid() % 20000);
  std::ostringstream conf;
  conf << "ClusterName=relittest\n"
       << "SlurmctldHost=" << host << "(127.0.0.1)\n"
       << "SlurmctldPort=" << port << "\nSlurmdPort=" << port + 1 << "\n"
       << "AuthType=auth/munge\nCredType=cred/munge\n"
       << "AuthInfo=socket=" << d << "/munge.socket\n"
       << "SlurmUser=root\nSlurmdUser=root\n"
       << "StateSaveLocation=" << d << "/state\nSlurmdSpoolDir=" << d << "/spool\n"
       << "SlurmctldPidFile=" << d << "/slurmctld.pid\nSlurmdPidFile=" << d << "/slurmd.pid\n"
       << "SlurmctldLogFile=" << d << "/log/slurmctld.log\nSlurmdLogFile=" << d << "/log/slurmd.log\n"
       << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n"
       << "JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\n"
       << "SchedulerType=sched/builtin\nSelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n"
       << "MpiDefault=none\nReturnToService=2\nMinJobAge=600\n"
       << "NodeName=" << host << " NodeAddr=127.0.0.1 CPUs=" << std::thread::hardware_concurrency()
       << " RealMemory=2000 State=UNKNOWN\n"
       << "PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n";
  WriteText(dir / "slurm.conf", conf.str());
  ::setenv("SLURM_CONF", (dir / "slurm.conf").c_str(), 1);

  const std::string q = ShellQuote(d);
  const std::string munged = "/usr/sbin/munged -f --socket=" + q + "/munge.socket --key-file=" + q +
                             "/munge.key --log-file=" + q + "/log/munged.log --pid-file=" + q +
                             "/munged.pid --seed-file=" + q + "/munge.seed";
  std::string err;
  if (RunCapture(munged, &out, &err) != 0) {
    *why_not = "munged did not start: " + err + cluster->Logs();
    return nullptr;
  }
  if (RunCapture("/usr/sbin/slurmctld -i", &out, &err) != 0) {
    *why_not = "slurmctld did not start: " + err + cluster->Logs();
    return nullptr;
  }
  if (RunCapture("/usr/sbin/slurmd -N " + ShellQuote(host), &out, &err) != 0) {
    *why_not = "slurmd did not start: " + err + cluster->Logs();
    return nullptr;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    if (RunCapture("sinfo -h -o %t", &out) == 0 && out.find("idle") != std::string::npos) {
      return cluster;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  *why_not = "the Slurm node did not become idle within 60 s: " + cluster->Logs();
  return nullptr;
}

SlurmCluster::~SlurmCluster() { Stop(); }

void SlurmCluster::Stop() {
  // Only the daemons this object started (their pid files are in dir_).
  for (const char* pid_file : {"slurmd.pid", "slurmctld.pid", "munged.pid"}) {
    const pid_t pid = ReadPid(dir_ / pid_file);
    if (pid <= 0) continue;
    ::kill(pid, SIGTERM);
    for (int i = 0; i < 100 && ::kill(pid, 0) == 0; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (::kill(pid, 0) == 0) ::kill(pid, SIGKILL);
  }
}

std::string SlurmCluster::Logs() const {
  std::string text;
  for (const char* log : {"munged.log", "slurmctld.log", "slurmd.log"}) {
    const std::string tail = ReadText(dir_ / "log" / log);
    text += "\n--- " + std::string(log) + " (end) ---\n" +
            (tail.size() > 2000 ? tail.substr(tail.size() - 2000) : tail);
  }
  return text;
}

}  // namespace relit::pipeline::testing
