// A run's output folder (output safety): dsnake writes only into a folder it owns,
// replaces only the files it wrote, and cleans up what a killed run left.
//
// A folder is dsnake's when it is new, empty, or holds an earlier result: the manifest
// (kOutputManifest, the list of files the last run wrote, relative to the folder) or, from
// builds before the manifest, a result.json written by dsnake. Anything else (the file system
// root, a file, a folder of the user's) is refused with one line naming --out, unless --force.
// Publishing moves the staged files in one by one (result.json last) and removes the files of
// the earlier manifest that this run did not write again (a 3D run's final.ply after a 2D run
// into the same folder); a file of the user's inside an output folder (snapshots/thesis.tex) is
// never touched, and folders are removed only when they end up empty.
#pragma once

#include <filesystem>
#include <string>

namespace dsnake {

inline constexpr const char* kOutputManifest = ".dsnake-outputs";

// Throws InputError("", "--out", ...) unless `out` may receive a run's outputs (see above).
// force: accept a non-empty folder without an earlier result (never the root or a file).
void check_output_folder(const std::filesystem::path& out, bool force);

// The staging folder of this process for `out` ("<out>.partial-<pid>"), after removing the
// staging folders of `out` whose process no longer runs. Created empty; a folder that cannot
// be created is an InputError naming --out.
std::filesystem::path make_staging_folder(const std::filesystem::path& out);

// Moves every file of `staging` into `out` (created if missing; a rename of the whole folder
// when it is new), removes the files of the earlier manifest not written again, writes the new
// manifest, then result.json; removes `staging`.
void publish_outputs(const std::filesystem::path& staging, const std::filesystem::path& out);

// Whether a process still runs (a zombie counts as ended).
bool process_alive(long pid);

// The pid in "<name>.partial-<pid>" (a run's staging) or ".tmp-<pid>-..." (atomic writes), or -1.
long owner_pid(const std::string& name);

}  // namespace dsnake
