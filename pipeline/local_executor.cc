// Local execution: each step is a child process in its own process group
// (so stopping a step also stops what it started, e.g. COLMAP or ffmpeg),
// with stdout and stderr appended to the step's log file.
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <system_error>
#include <thread>

#include "core/error.h"
#include "core/run_record.h"
#include "core/shell.h"
#include "pipeline/executor.h"

namespace relit::pipeline {

namespace {

std::string CommandText(const std::vector<std::string>& argv) {
  std::string text;
  for (const std::string& a : argv) text += (text.empty() ? "" : " ") + ShellQuote(a);
  return text;
}

JobResult FromWaitStatus(const std::string& step, int status, pid_t pid) {
  JobResult r;
  r.step = step;
  r.job_id = "pid " + std::to_string(pid);
  if (WIFEXITED(status)) {
    r.exit_code = WEXITSTATUS(status);
    r.ok = r.exit_code == 0;
    if (!r.ok) r.message = "exit code " + std::to_string(r.exit_code);
  } else if (WIFSIGNALED(status)) {
    r.exit_code = 128 + WTERMSIG(status);
    r.message = std::string("killed by signal ") + strsignal(WTERMSIG(status));
  } else {
    r.exit_code = 1;
    r.message = "ended abnormally";
  }
  return r;
}

}  // namespace

LocalExecutor::~LocalExecutor() { CancelAll(); }

void LocalExecutor::Submit(const std::vector<Job>& jobs) {
  for (const Job& job : jobs) {
    const int log = ::open(job.log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    RELIT_REQUIRE(log >= 0, "cannot open log file ", job.log_path, ": ", std::strerror(errno));
    const std::string header = "=== relit " + CurrentTimeIso8601Utc() + ": " + CommandText(job.argv) + "\n";
    if (::write(log, header.data(), header.size()) < 0) {
      // The header is a courtesy; the command's own output still goes there.
    }
    // Everything the child needs is prepared before fork(): after it, only
    // async-signal-safe calls are allowed.
    std::vector<char*> argv;
    for (const std::string& a : job.argv) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const pid_t parent = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) {
      ::close(log);
      Fail("cannot start ", job.step, ": fork failed: ", std::strerror(errno));
    }
    if (pid == 0) {
      ::setpgid(0, 0);
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // relit killed -> the step stops too
      if (::getppid() != parent) ::_exit(143);
      const int null = ::open("/dev/null", O_RDONLY);
      if (null >= 0) ::dup2(null, 0);
      ::dup2(log, 1);
      ::dup2(log, 2);
      if (!job.work_dir.empty() && ::chdir(job.work_dir.c_str()) != 0) ::_exit(126);
      ::execv(argv[0], argv.data());
      const char* message = "relit: cannot execute the step's command\n";
      if (::write(2, message, std::strlen(message)) < 0) ::_exit(127);
      ::_exit(127);
    }
    ::setpgid(pid, pid);  // also here, so CancelAll cannot race the child's own call
    ::close(log);
    running_[pid] = job.step;
  }
}

std::vector<JobResult> LocalExecutor::Poll() {
  std::vector<JobResult> results;
  for (auto it = running_.begin(); it != running_.end();) {
    int status = 0;
    const pid_t done = ::waitpid(it->first, &status, WNOHANG);
    if (done == it->first) {
      results.push_back(FromWaitStatus(it->second, status, it->first));
      ::kill(-it->first, SIGKILL);  // leftovers of the step's process group
      it = running_.erase(it);
    } else {
      ++it;
    }
  }
  return results;
}

void LocalExecutor::CancelAll() {
  if (running_.empty()) return;
  for (const auto& [pid, step] : running_) ::kill(-pid, SIGTERM);
  // Give the steps a few seconds to stop cleanly (they write atomically, so
  // stopping them hard is safe too, only slower to resume).
  for (int i = 0; i < 50 && !running_.empty(); ++i) {
    Poll();
    if (!running_.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  for (const auto& [pid, step] : running_) ::kill(-pid, SIGKILL);
  for (const auto& [pid, step] : running_) {
    int status = 0;
    ::waitpid(pid, &status, 0);
  }
  running_.clear();
}

std::string LocalExecutor::JobIdOf(const std::string& step) const {
  for (const auto& [pid, name] : running_) {
    if (name == step) return "pid " + std::to_string(pid);
  }
  return "";
}

std::string CommandStderrTemplate() {
  // temp_directory_path() reads TMPDIR (POSIX); it fails when TMPDIR names
  // no directory, and /tmp is then what every other tool would use.
  std::error_code ec;
  std::filesystem::path dir = std::filesystem::temp_directory_path(ec);
  if (ec || dir.empty()) dir = "/tmp";
  return (dir / "relit-cmd-XXXXXX").string();
}

int RunCapture(const std::string& command, std::string* out, std::string* err) {
  std::string full = command;
  std::string err_template = CommandStderrTemplate();
  char* err_path = err_template.data();  // mkstemp fills in the XXXXXX
  int err_fd = -1;
  if (err) {
    err_fd = ::mkstemp(err_path);
    if (err_fd >= 0) full += " 2>" + ShellQuote(err_path);
  } else {
    full += " 2>/dev/null";
  }
  FILE* pipe = ::popen(full.c_str(), "r");
  if (!pipe) {
    if (err_fd >= 0) {
      ::close(err_fd);
      ::unlink(err_path);
    }
    return -1;
  }
  std::string text;
  char buffer[4096];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) text.append(buffer, n);
  const int status = ::pclose(pipe);
  if (out) *out = text;
  if (err_fd >= 0) {
    std::string e;
    while (true) {
      const ssize_t r = ::read(err_fd, buffer, sizeof(buffer));
      if (r <= 0) break;
      e.append(buffer, static_cast<size_t>(r));
    }
    ::close(err_fd);
    ::unlink(err_path);
    *err = e;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

}  // namespace relit::pipeline
