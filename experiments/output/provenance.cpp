#include "experiments/output/provenance.h"

#include "experiments/output/runner.h"
#include "framework/core/errors.h"

#include <array>
#include <filesystem>
#include <fstream>
#include <memory>
#include <omp.h>
#include <openssl/evp.h>
#include <sys/resource.h>
#include <unistd.h>

namespace dsnake {

namespace fs = std::filesystem;

const std::vector<std::string>& input_file_pointers() {
  static const std::vector<std::string> pointers = {
      "/image/file",           "/image/mesh",         "/template/file",       "/template/mesh",
      "/template/reference_image", "/template/init/mask", "/template/start", "/ground_truth/mask",
      "/ground_truth/surface", "/ground_truth/correspondence"};
  return pointers;
}

std::vector<InputFile> input_files(const nlohmann::json& document, const std::string& base_dir) {
  std::vector<InputFile> files;
  for (const std::string& pointer : input_file_pointers()) {
    const nlohmann::json::json_pointer p(pointer);
    if (!document.contains(p) || !document[p].is_string() || document[p].get<std::string>().empty()) continue;
    fs::path path = document[p].get<std::string>();
    if (path.is_relative() && !base_dir.empty()) path = fs::path(base_dir) / path;
    std::string key = pointer.substr(1);
    for (char& c : key)
      if (c == '/') c = '.';
    files.push_back({key, path.lexically_normal().string()});
  }
  return files;
}

std::string file_sha256(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot be read");
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
  if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256 is not available (OpenSSL)");
  std::vector<char> buffer(size_t(1) << 20);
  while (in) {
    in.read(buffer.data(), std::streamsize(buffer.size()));
    if (in.gcount() > 0) EVP_DigestUpdate(ctx.get(), buffer.data(), size_t(in.gcount()));
  }
  if (in.bad()) throw InputError(path, "", "cannot be read");
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int length = 0;
  EVP_DigestFinal_ex(ctx.get(), digest.data(), &length);
  static const char* kHex = "0123456789abcdef";
  std::string hex;
  for (unsigned int i = 0; i < length; ++i) hex += {kHex[digest[i] >> 4], kHex[digest[i] & 15]};
  return hex;
}

nlohmann::ordered_json build_json() {
  return {{"version", dsnake_version()},
          {"compiler", DSNAKE_BUILD_COMPILER},
          {"flags", DSNAKE_BUILD_FLAGS},
          {"build_type", DSNAKE_BUILD_TYPE}};
}

nlohmann::ordered_json input_files_json(const nlohmann::json& document, const std::string& base_dir) {
  nlohmann::ordered_json inputs = nlohmann::ordered_json::object();
  for (const InputFile& f : input_files(document, base_dir)) {
    std::error_code ec;
    const auto bytes = fs::file_size(f.path, ec);
    if (ec) throw InputError(f.path, "", "cannot be read");
    inputs[f.key] = {{"path", fs::absolute(f.path).lexically_normal().string()},
                     {"bytes", bytes},
                     {"sha256", file_sha256(f.path)}};
  }
  return inputs;
}

std::string utc_timestamp(std::chrono::system_clock::time_point t) {
  const std::time_t s = std::chrono::system_clock::to_time_t(t);
  std::tm utc{};
  gmtime_r(&s, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

nlohmann::ordered_json provenance_json(const ProvenanceContext& c) {
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;
  nlohmann::ordered_json p;
  p["build"] = build_json();
  p["host"] = host;
  p["threads"] = omp_get_max_threads();
  p["command_line"] = c.command_line;
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) == 0) p["peak_memory_mb"] = double(usage.ru_maxrss) / 1024.0;  // ru_maxrss: kB
  p["started"] = utc_timestamp(c.started);
  p["finished"] = utc_timestamp(c.finished);
  p["inputs"] = c.document ? input_files_json(*c.document, c.base_dir) : nlohmann::ordered_json::object();
  return p;
}

}  // namespace dsnake
