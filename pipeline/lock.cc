#include "pipeline/lock.h"

#include <algorithm>
#include <filesystem>
#include <set>

#include "core/error.h"
#include "core/json_file.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

namespace {

std::string Short(const nlohmann::json& value) {
  std::string text = value.is_null() ? "unset" : value.is_string() ? value.get<std::string>() : value.dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

void Diff(const nlohmann::json& before, const nlohmann::json& now, const std::string& prefix,
          std::vector<std::string>* changes) {
  if (before == now) return;
  if (before.is_object() && now.is_object()) {
    std::set<std::string> keys;
    for (const auto& item : before.items()) keys.insert(item.key());
    for (const auto& item : now.items()) keys.insert(item.key());
    for (const std::string& key : keys) {
      const nlohmann::json a = before.contains(key) ? before[key] : nlohmann::json();
      const nlohmann::json b = now.contains(key) ? now[key] : nlohmann::json();
      Diff(a, b, prefix.empty() ? key : prefix + "." + key, changes);
    }
    return;
  }
  // A section that is absent and one that is empty mean the same: defaults.
  const auto empty = [](const nlohmann::json& j) { return j.is_null() || (j.is_object() && j.empty()); };
  if (empty(before) && empty(now)) return;
  if (before.is_object() && now.is_null()) return Diff(before, nlohmann::json::object(), prefix, changes);
  if (before.is_null() && now.is_object()) return Diff(nlohmann::json::object(), now, prefix, changes);
  changes->push_back(prefix + " (" + Short(before) + " -> " + Short(now) + ")");
}

}  // namespace

LockFile::LockFile(std::string workspace) : workspace_(std::move(workspace)) {
  std::error_code error;
  if (!fs::exists(path(), error)) return;
  const nlohmann::json j = ReadJsonFile(path(), kKind, kVersion);
  if (j.contains("steps") && j["steps"].is_object()) steps_ = j["steps"];
}

std::string LockFile::path() const { return (fs::path(workspace_) / "relit.lock.json").string(); }

const nlohmann::json* LockFile::Entry(const std::string& step) const {
  const auto it = steps_.find(step);
  return it == steps_.end() ? nullptr : &*it;
}

void LockFile::Set(const std::string& step, nlohmann::json entry) { steps_[step] = std::move(entry); }

void LockFile::Remove(const std::string& step) { steps_.erase(step); }

std::vector<std::string> LockFile::StepNames() const {
  std::vector<std::string> names;
  for (const auto& item : steps_.items()) names.push_back(item.key());
  return names;
}

std::string LockFile::OutputHash(const std::string& step) const {
  const nlohmann::json* entry = Entry(step);
  if (!entry || entry->value("status", "") != "done") return "";
  return entry->value("/output/sha256"_json_pointer, std::string());
}

void LockFile::Save() const { WriteJsonFile(path(), kKind, kVersion, {{"steps", steps_}}); }

std::vector<std::string> ParameterChanges(const nlohmann::json& before, const nlohmann::json& now) {
  std::vector<std::string> changes;
  Diff(before, now, "", &changes);
  return changes;
}

Evaluation Evaluate(const Step& step, const LockFile& lock, HashCache& hashes,
                    const std::string& output_dir, const std::string& tool_path,
                    const std::string& tool_searched) {
  Evaluation e;
  auto stale = [&](std::string reason) {
    e.stale = true;
    e.reasons.push_back(std::move(reason));
  };
  const std::string exe = StageExecutables().at(step.tool);
  e.tool_path = tool_path;
  if (tool_path.empty()) {
    e.tool_missing = true;
    stale("tool " + exe + " not found (looked in " + tool_searched + ")");
  } else {
    e.tool_sha256 = hashes.HashFile(tool_path);
  }
  e.params_sha256 = HashJson(step.params);
  for (const StepInput& input : step.inputs) {
    const std::string sha = hashes.HashPath(input.path);
    if (sha.empty()) {
      stale("input " + input.role + " missing: " + input.path);
    } else {
      e.inputs[input.role] = sha;
    }
  }
  for (const std::string& dep : step.deps) {
    const std::string sha = lock.OutputHash(dep);
    if (sha.empty()) {
      stale("upstream step " + dep + " has no accepted output");
    } else {
      e.inputs["step:" + dep] = sha;
    }
  }

  const nlohmann::json* entry = lock.Entry(step.name);
  if (!entry) {
    stale("never run");
    return e;
  }
  const std::string status = entry->value("status", "");
  if (status == "running") {
    stale("interrupted: a run stopped while this step was running (started " +
          entry->value("started_utc", std::string("?")) + "); its output was not accepted");
    return e;
  }
  if (status == "failed") {
    stale("failed last time (" + entry->value("message", std::string("error")) + "; log " +
          entry->value("log", std::string("?")) + ")");
    return e;
  }
  if (!e.tool_missing && entry->value("/tool/sha256"_json_pointer, std::string()) != e.tool_sha256) {
    stale("tool " + exe + " changed (rebuilt or replaced: " + tool_path + ")");
  }
  if (entry->value("params_sha256", "") != e.params_sha256) {
    const auto changes = ParameterChanges(entry->value("params", nlohmann::json()), step.params);
    if (changes.empty()) {
      stale("parameters changed");
    } else {
      for (const std::string& change : changes) stale("parameter " + change + " changed");
    }
  }
  const nlohmann::json recorded = entry->value("inputs", nlohmann::json::object());
  for (const auto& [role, sha] : e.inputs.items()) {
    if (!recorded.contains(role)) {
      stale(role.rfind("step:", 0) == 0 ? "now reads upstream " + role.substr(5)
                                        : "input " + role + " added");
    } else if (recorded[role] != sha) {
      if (role.rfind("step:", 0) == 0) {
        stale("upstream " + role.substr(5) + " output changed");
      } else {
        stale("input " + role + " changed");
      }
    }
  }
  for (const auto& item : recorded.items()) {
    const bool missing_now = std::none_of(step.inputs.begin(), step.inputs.end(),
                                          [&](const StepInput& in) { return in.role == item.key(); }) &&
                             std::find(step.deps.begin(), step.deps.end(),
                                       item.key().substr(item.key().rfind(':') + 1)) == step.deps.end();
    if (missing_now) stale("input " + item.key() + " removed");
  }
  const std::string output = hashes.HashPath(output_dir);
  if (output.empty()) {
    stale("output " + output_dir + " missing");
  } else if (output != entry->value("/output/sha256"_json_pointer, std::string())) {
    stale("output " + output_dir + " changed since relit accepted it");
  }
  return e;
}

}  // namespace relit::pipeline
