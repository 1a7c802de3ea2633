// Where a result came from, recorded in result.json's "provenance" so that a result can be
// traced to its inputs and build, and a sweep can tell a result that still stands from a stale
// one (experiments/sweep/sweep.h):
//   "build":        version (git describe), compiler, flags and build type of this executable
//   "host", "threads" (OpenMP threads), "command_line" (as given; ["dsnake.run"] from Python),
//   "peak_memory_mb" (the process's peak resident memory so far: a sweep's Slurm script asks
//                   for memory from it)
//   "started", "finished": UTC, ISO 8601 to the second
//   "inputs":       per input file the experiment names ("image.file", "template.reference_image",
//                   ...): its path, size in bytes and SHA-256 (as `sha256sum` prints it)
#pragma once

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace dsnake {

// The experiment document's keys that name input files, as JSON pointers ("/image/file", ...).
const std::vector<std::string>& input_file_pointers();

// An input file named by an experiment document: its key ("image.file") and its path resolved
// against `base_dir` (the experiment file's folder; "" leaves it as written).
struct InputFile {
  std::string key, path;
};
std::vector<InputFile> input_files(const nlohmann::json& document, const std::string& base_dir);

// The SHA-256 of a file's bytes, lower-case hex; throws InputError naming the file when it cannot
// be read.
std::string file_sha256(const std::string& path);

// {"version", "compiler", "flags", "build_type"} of this build.
nlohmann::ordered_json build_json();

// The input files' records: {"image.file": {"path", "bytes", "sha256"}, ...}.
nlohmann::ordered_json input_files_json(const nlohmann::json& document, const std::string& base_dir);

// A time as UTC ISO 8601 to the second ("2026-12-06T12:34:56Z").
std::string utc_timestamp(std::chrono::system_clock::time_point t);

struct ProvenanceContext {
  const nlohmann::json* document = nullptr;  // the experiment as run
  std::string base_dir;                      // where its relative paths resolve
  std::vector<std::string> command_line;     // as given ("" entries dropped)
  std::chrono::system_clock::time_point started, finished;
};
nlohmann::ordered_json provenance_json(const ProvenanceContext& context);

}  // namespace dsnake
