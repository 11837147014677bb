// Slurm execution: steps submitted together become one sbatch array job
// whose task K runs the step with array index K (the partition index for
// training). The job script appends the command's output to the step's log
// and writes the exit status to <step dir>/exit_code, so the result is read
// from the shared workspace and no accounting database (sacct) is needed; when
// a task ends without writing it (time limit, memory, node failure) its state
// comes from scontrol, else sacct.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/shell.h"
#include "pipeline/executor.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

namespace {

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r\n") - a + 1);
}

// "KEY=value" from scontrol's "A=1 B=2" output.
std::string Field(const std::string& text, const std::string& key) {
  const size_t at = text.find(" " + key + "=");
  const size_t start = at == std::string::npos ? (text.rfind(key + "=", 0) == 0 ? 0 : std::string::npos)
                                               : at + 1;
  if (start == std::string::npos) return "";
  const size_t value = start + key.size() + 1;
  const size_t end = text.find_first_of(" \n", value);
  return text.substr(value, end == std::string::npos ? std::string::npos : end - value);
}

}  // namespace

SlurmExecutor::SlurmExecutor(SlurmOptions options, std::string slurm_dir)
    : options_(std::move(options)), slurm_dir_(std::move(slurm_dir)) {}

SlurmExecutor::~SlurmExecutor() { CancelAll(); }

std::string SlurmExecutor::JobScript(const std::vector<Job>& jobs, const std::vector<int>& indices) {
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# Written by relit run: " << jobs.size() << " step(s) of kind " << jobs.front().kind << ".\n"
    << "# Array task K runs the step listed under K; its output is appended to\n"
    << "# the step's log, its exit status written to <step dir>/exit_code.\n"
    << "case \"${SLURM_ARRAY_TASK_ID:-" << indices.front() << "}\" in\n";
  for (size_t i = 0; i < jobs.size(); ++i) {
    const Job& job = jobs[i];
    s << "  " << indices[i] << ")\n"
      << "    step_dir=" << ShellQuote(job.step_dir) << "\n"
      << "    log=" << ShellQuote(job.log_path) << "\n"
      << "    command=(";
    for (const std::string& a : job.argv) s << " " << ShellQuote(a);
    s << " ) ;;\n";
  }
  s << "  *) echo \"relit: no step for array task $SLURM_ARRAY_TASK_ID\" >&2; exit 2 ;;\n"
    << "esac\n"
    << "cd " << ShellQuote(jobs.front().work_dir) << " || exit 2\n"
    << "echo \"=== relit: slurm job ${SLURM_JOB_ID}${SLURM_ARRAY_TASK_ID:+ (array task "
       "$SLURM_ARRAY_TASK_ID)} on $(hostname) at $(date -u +%FT%TZ)\" >>\"$log\"\n"
    << "\"${command[@]}\" </dev/null >>\"$log\" 2>&1\n"
    << "code=$?\n"
    << "echo \"$code\" >\"$step_dir/exit_code.tmp\" && mv -f \"$step_dir/exit_code.tmp\" "
       "\"$step_dir/exit_code\"\n"
    << "exit \"$code\"\n";
  return s.str();
}

void SlurmExecutor::Submit(const std::vector<Job>& jobs) {
  if (jobs.empty()) return;
  std::vector<int> indices;
  std::set<int> distinct;
  for (size_t i = 0; i < jobs.size(); ++i) {
    indices.push_back(jobs[i].array_index >= 0 ? jobs[i].array_index : static_cast<int>(i));
    distinct.insert(indices.back());
  }
  if (distinct.size() != jobs.size()) {
    for (size_t i = 0; i < jobs.size(); ++i) indices[i] = static_cast<int>(i);
  }
  for (const Job& job : jobs) {
    fs::create_directories(job.step_dir);
    fs::remove(fs::path(job.step_dir) / "exit_code");
  }
  fs::create_directories(slurm_dir_);
  const std::string kind = jobs.front().kind;
  const std::string script =
      (fs::path(slurm_dir_) / (kind + "-" + std::to_string(::getpid()) + "-" +
                               std::to_string(script_counter_++) + ".sh"))
          .string();
  AtomicWriteFile(script, JobScript(jobs, indices));
  fs::permissions(script, fs::perms::owner_all, fs::perm_options::add);

  const SlurmResources& r = options_.For(kind);
  const bool array = jobs.size() > 1;
  const std::string output = (fs::path(slurm_dir_) / (array ? "slurm-%A_%a.out" : "slurm-%j.out")).string();
  std::string command = ShellQuote(options_.sbatch) + " --parsable --job-name " +
                        ShellQuote("relit-" + kind) + " --chdir " + ShellQuote(jobs.front().work_dir) +
                        " --output " + ShellQuote(output) + " --cpus-per-task " +
                        std::to_string(r.cpus) + " --mem " + ShellQuote(r.memory) + " --time " +
                        ShellQuote(r.time);
  if (!r.partition.empty()) command += " --partition " + ShellQuote(r.partition);
  if (!r.account.empty()) command += " --account " + ShellQuote(r.account);
  if (r.gpus > 0) command += " --gres " + ShellQuote("gpu:" + std::to_string(r.gpus));
  if (array) {
    std::string list;
    for (int i : indices) list += (list.empty() ? "" : ",") + std::to_string(i);
    command += " --array " + list;
  }
  for (const std::string& extra : r.extra_args) command += " " + ShellQuote(extra);
  command += " " + ShellQuote(script);

  std::string out, err;
  const int status = RunCapture(command, &out, &err);
  const std::string job_id = Trim(out.substr(0, out.find(';')));
  RELIT_REQUIRE(status == 0 && !job_id.empty() &&
                    job_id.find_first_not_of("0123456789") == std::string::npos,
                "sbatch failed for ", jobs.size(), " ", kind, " step(s) (exit ", status,
                "): ", Trim(err.empty() ? out : err), "; command: ", command);
  for (size_t i = 0; i < jobs.size(); ++i) {
    Task t;
    t.step = jobs[i].step;
    t.job_id = array ? job_id + "_" + std::to_string(indices[i]) : job_id;
    t.step_dir = jobs[i].step_dir;
    t.log_path = jobs[i].log_path;
    t.slurm_output = array ? (fs::path(slurm_dir_) / ("slurm-" + job_id + "_" + std::to_string(indices[i]) + ".out")).string()
                           : (fs::path(slurm_dir_) / ("slurm-" + job_id + ".out")).string();
    tasks_.push_back(t);
    spdlog::info("{}: submitted as Slurm job {} (log {})", t.step, t.job_id, t.log_path);
  }
  next_poll_ = std::chrono::steady_clock::now();
}

JobResult SlurmExecutor::Finished(const Task& task) const {
  JobResult r;
  r.step = task.step;
  r.job_id = task.job_id;
  std::ifstream in(fs::path(task.step_dir) / "exit_code");
  int code = 0;
  if (in >> code) {
    r.exit_code = code;
    r.ok = code == 0;
    if (!r.ok) {
      r.message = "Slurm job " + task.job_id + " failed with exit code " + std::to_string(code) +
                  " (log " + task.log_path + ")";
    }
    return r;
  }
  // No exit status: the script itself was stopped (time limit, memory,
  // cancelled, node failure). Ask Slurm why.
  std::string state, out;
  if (RunCapture(ShellQuote(options_.scontrol) + " -o show job " + ShellQuote(task.job_id), &out) == 0) {
    state = Field(out, "JobState");
    if (!state.empty()) state += ", exit " + Field(out, "ExitCode");
  }
  if (state.empty() &&
      RunCapture(ShellQuote(options_.sacct) + " -n -P -X -o State,ExitCode -j " + ShellQuote(task.job_id),
                 &out) == 0) {
    state = Trim(out.substr(0, out.find('\n')));
  }
  r.exit_code = 1;
  r.message = "Slurm job " + task.job_id + " ended without finishing the step (" +
              (state.empty() ? "state unknown" : state) + "; log " + task.log_path +
              ", Slurm output " + task.slurm_output + ")";
  return r;
}

std::vector<JobResult> SlurmExecutor::Poll() {
  std::vector<JobResult> results;
  if (tasks_.empty() || std::chrono::steady_clock::now() < next_poll_) return results;
  next_poll_ = std::chrono::steady_clock::now() +
               std::chrono::milliseconds(static_cast<int64_t>(options_.poll_s * 1000));
  std::set<std::string> jobs;
  for (const Task& t : tasks_) jobs.insert(t.job_id.substr(0, t.job_id.find('_')));
  std::string list;
  for (const std::string& j : jobs) list += (list.empty() ? "" : ",") + j;
  std::string out, err;
  const int status =
      RunCapture(ShellQuote(options_.squeue) + " -h -r -o '%i' -j " + ShellQuote(list), &out, &err);
  if (status != 0) {
    // squeue exits non-zero when none of the jobs is known any more (they
    // all left the queue) but also when the controller is unreachable; the
    // exit_code files tell finished jobs apart, the others are kept.
    spdlog::debug("squeue: exit {}: {}", status, Trim(err));
    out.clear();
  }
  std::set<std::string> queued;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    if (!Trim(line).empty()) queued.insert(Trim(line));
  }
  for (auto it = tasks_.begin(); it != tasks_.end();) {
    const bool in_queue = queued.count(it->job_id) > 0;
    const bool have_code = fs::exists(fs::path(it->step_dir) / "exit_code");
    const bool controller_down = status != 0 && err.find("Invalid job id") == std::string::npos;
    if (in_queue || (!have_code && controller_down)) {
      ++it;
      continue;
    }
    results.push_back(Finished(*it));
    it = tasks_.erase(it);
  }
  return results;
}

void SlurmExecutor::CancelAll() {
  if (tasks_.empty()) return;
  std::string ids;
  for (const Task& t : tasks_) ids += " " + ShellQuote(t.job_id);
  std::string out;
  RunCapture(ShellQuote(options_.scancel) + ids, &out);
  tasks_.clear();
}

std::string SlurmExecutor::JobIdOf(const std::string& step) const {
  for (const Task& t : tasks_) {
    if (t.step == step) return "slurm job " + t.job_id;
  }
  return "";
}

}  // namespace relit::pipeline
