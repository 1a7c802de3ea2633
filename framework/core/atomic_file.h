// Atomic output: a file is written under a temporary name in the same folder and renamed into
// place, so that a failure or a kill never leaves a half-written file under the final name.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace dsnake {

// An output that could not be written (a full disk, a read-only folder, a file size limit): names
// the file and the system's reason, on one line. Not the input's fault: main.cpp prints it as a
// "dsnake: error:" line with exit code 1; the writers here leave no partial file behind.
class OutputError : public std::runtime_error {
 public:
  OutputError(const std::string& file, const std::string& reason);
};

// Writes `bytes` to `path` atomically. Throws OutputError (framework/core/errors.h) naming the
// path and the system's reason (a full disk) on failure.
void write_file_atomically(const std::string& path, const std::string& bytes);
// The same for a file made of `parts` one after another (a header and an image's own values),
// without joining them in memory first.
void write_file_atomically(const std::string& path, const std::vector<std::string_view>& parts);

// The same for a file whose bytes `produce` makes a piece at a time, handing each to `put` (a
// gzip stream as it is compressed: the file's bytes are never held whole).
void write_stream_atomically(const std::string& path,
                             const std::function<void(const std::function<void(std::string_view)>& put)>& produce);

// For writers that need a file name (OpenMesh, OpenCV): `write` receives a temporary path in
// the same folder that keeps the final extension (".../.tmp-<pid>-<n>-name.ply"); it is renamed
// to `path` when `write` returns, and removed if `write` throws.
void write_via_temporary(const std::string& path, const std::function<void(const std::string& tmp_path)>& write);

}  // namespace dsnake
