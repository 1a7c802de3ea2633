// A run's output folder; see output_folder.h.
#include "experiments/output/output_folder.h"
#include "experiments/output/report_step.h"

#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <fstream>
#include <iterator>
#include <set>
#include <unistd.h>
#include <vector>

namespace dsnake {

namespace fs = std::filesystem;

namespace {

constexpr std::uintmax_t kLargestResultJson = std::uintmax_t(64) << 20;  // bytes read to recognise one

[[noreturn]] void refuse(const fs::path& out, const std::string& why) {
  throw InputError("", "--out", out.string() + ": " + why);
}

// `out` without a trailing separator, so that its file name is the folder's name.
fs::path folder_path(const fs::path& out) {
  fs::path p = out.lexically_normal();
  if (p.filename().empty() && p.has_parent_path()) p = p.parent_path();
  return p;
}

// A result.json that dsnake wrote: a JSON object with its "version" and "config".
bool is_dsnake_result(const fs::path& file) {
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec || size > kLargestResultJson || !fs::is_regular_file(file, ec)) return false;
  std::ifstream in(file);
  const auto doc = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  return doc.is_object() && doc.contains("version") && doc.contains("config");
}

bool holds_result(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / kOutputManifest, ec) || is_dsnake_result(dir / "result.json");
}

// The manifest's entries that name a file inside the folder (no absolute paths, no "..").
std::set<std::string> read_manifest(const fs::path& dir) {
  std::set<std::string> files;
  std::ifstream in(dir / kOutputManifest);
  for (std::string line; std::getline(in, line);) {
    const fs::path rel = fs::path(line).lexically_normal();
    if (line.empty() || rel.is_absolute() || rel.empty() || *rel.begin() == "..") continue;
    files.insert(rel.generic_string());
  }
  return files;
}

// The files under `dir`, relative to it, sorted.
std::vector<std::string> files_under(const fs::path& dir) {
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (!e.is_directory()) files.push_back(e.path().lexically_relative(dir).generic_string());
  std::sort(files.begin(), files.end());
  return files;
}

// Removes the folders from `dir` up to (not including) `root` while they are empty.
void remove_empty_folders(fs::path dir, const fs::path& root) {
  std::error_code ec;
  while (!dir.empty() && dir != root && fs::is_directory(dir, ec) && fs::is_empty(dir, ec)) {
    fs::remove(dir, ec);
    dir = dir.parent_path();
  }
}

// Before anything moves: every file this run writes can take its place (a folder of the user's
// in the way, or a file of the user's where a folder must be, is refused).
void check_targets(const fs::path& out, const std::vector<std::string>& files, const std::set<std::string>& ours) {
  std::error_code ec;
  for (const std::string& rel : files) {
    fs::path at = out;
    for (const auto& part : fs::path(rel).parent_path()) {
      at /= part;
      const fs::path from_out = at.lexically_relative(out);
      if (fs::exists(at, ec) && !fs::is_directory(at, ec) && !ours.count(from_out.generic_string()))
        refuse(out, "'" + from_out.generic_string() + "' is a file of yours where dsnake writes a folder");
    }
    const fs::path target = out / rel;
    if (fs::is_directory(target, ec) && !fs::is_empty(target, ec))
      refuse(out, "'" + rel + "' is a folder of yours where dsnake writes a file");
  }
}

}  // namespace

bool process_alive(long pid) {
  if (pid <= 0) return false;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  if (stat) {
    // A killed run whose parent died stays a zombie until init reaps it, and kill(pid, 0)
    // succeeds on a zombie: /proc tells the two apart ("pid (comm) state ...").
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const auto close = text.rfind(')');
    const char state = close != std::string::npos && close + 2 < text.size() ? text[close + 2] : '?';
    return state != 'Z' && state != 'X';
  }
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH;
}

long owner_pid(const std::string& name) {
  std::string digits;
  if (auto p = name.rfind(".partial-"); p != std::string::npos) digits = name.substr(p + 9);
  else if (name.rfind(".tmp-", 0) == 0) digits = name.substr(5, name.find('-', 5) - 5);
  if (digits.empty() || digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos) return -1;
  return std::stol(digits);
}

void check_output_folder(const fs::path& out, bool force) {
  std::error_code ec;
  fs::path full = fs::absolute(folder_path(out), ec);
  if (!ec) full = fs::weakly_canonical(full, ec);
  if (ec) refuse(out, ec.message());
  if (full == full.root_path() || full.relative_path().empty()) refuse(out, "the file system root is not an output folder");
  const fs::file_status st = fs::status(full, ec);
  if (ec && st.type() != fs::file_type::not_found) refuse(out, ec.message());
  if (!fs::exists(st)) return;
  if (!fs::is_directory(st)) refuse(out, "a file, not a folder");
  if (fs::is_empty(full, ec) || holds_result(full) || force) return;
  refuse(out, "a folder that holds no earlier dsnake result and is not empty (--force writes into it; dsnake then "
              "replaces only the files it writes)");
}

fs::path make_staging_folder(const fs::path& out) {
  const fs::path folder = folder_path(out);
  const fs::path parent = folder.has_parent_path() ? folder.parent_path() : fs::path(".");
  const std::string prefix = folder.filename().string() + ".partial-";
  std::error_code ec;
  if (fs::is_directory(parent, ec))
    for (const auto& e : fs::directory_iterator(parent, ec)) {
      const std::string name = e.path().filename().string();
      if (name.rfind(prefix, 0) != 0) continue;
      const long pid = owner_pid(name);
      std::error_code ignored;
      if (pid > 0 && !process_alive(pid)) fs::remove_all(e.path(), ignored);
    }
  const fs::path staging = fs::path(folder.string() + ".partial-" + std::to_string(::getpid()));
  fs::remove_all(staging, ec);
  if (!fs::create_directories(staging, ec) || ec)
    refuse(out, "cannot create the staging folder " + staging.string() + (ec ? ": " + ec.message() : ""));
  return staging;
}

void publish_outputs(const fs::path& staging, const fs::path& out_arg) {
  const fs::path out = folder_path(out_arg);
  try {
    const std::vector<std::string> files = files_under(staging);
    std::string manifest;
    for (const std::string& f : files) manifest += f + "\n";
    std::error_code ec;
    if (!fs::exists(out, ec)) {  // a new folder appears in one step
      std::ofstream(staging / kOutputManifest) << manifest;
      if (out.has_parent_path()) fs::create_directories(out.parent_path());
      fs::rename(staging, out, ec);
      if (!ec) return;
      fs::remove(staging / kOutputManifest, ec);
    }
    fs::create_directories(out);
    std::set<std::string> earlier = read_manifest(out);
    // The report step's files are written after the run (report_step.h): an earlier run's report
    // goes with it, and the report step makes this run's.
    for (const char* f : kReportFiles) earlier.insert(f);
    check_targets(out, files, earlier);
    // This run's files, result.json last (a folder with a new result.json is complete).
    std::vector<std::string> order = files;
    std::stable_partition(order.begin(), order.end(), [](const std::string& f) { return f != "result.json"; });
    const std::set<std::string> written(files.begin(), files.end());
    auto move_in = [&](const std::string& rel) {
      const fs::path target = out / rel;
      for (fs::path at = out; const auto& part : fs::path(rel).parent_path()) {
        at /= part;
        if (fs::exists(at) && !fs::is_directory(at)) fs::remove(at);  // an earlier output file of ours
      }
      fs::create_directories(target.parent_path());
      if (fs::is_directory(target)) fs::remove(target);  // empty (check_targets)
      fs::rename(staging / rel, target);
    };
    for (const std::string& rel : order)
      if (rel != "result.json") move_in(rel);
    // The earlier run's files that this run did not write again; user files are not listed.
    for (const std::string& rel : earlier) {
      if (written.count(rel)) continue;
      const fs::path stale = out / rel;
      if (fs::is_directory(fs::symlink_status(stale, ec))) continue;
      fs::remove(stale, ec);
      remove_empty_folders(stale.parent_path(), out);
    }
    write_file_atomically((out / kOutputManifest).string(), manifest);
    if (written.count("result.json")) move_in("result.json");
    fs::remove_all(staging, ec);
  } catch (const fs::filesystem_error& e) {
    throw InputError("", "--out", out.string() + ": cannot write the outputs: " + e.code().message());
  }
}

}  // namespace dsnake
