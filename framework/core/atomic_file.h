// Atomic output: a file is written under a temporary name in the same folder and renamed into
// place, so that a failure or a kill never leaves a half-written file under the final name.
#pragma once

#include <functional>
#include <string>

namespace dsnake {

// Writes `bytes` to `path` atomically. Throws std::runtime_error naming the path on failure.
void write_file_atomically(const std::string& path, const std::string& bytes);

// For writers that need a file name (OpenMesh, OpenCV): `write` receives a temporary path in
// the same folder that keeps the final extension (".../.tmp-<pid>-<n>-name.ply"); it is renamed
// to `path` when `write` returns, and removed if `write` throws.
void write_via_temporary(const std::string& path, const std::function<void(const std::string& tmp_path)>& write);

}  // namespace dsnake
