#include "experiments/output/report_step.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace dsnake {
namespace {

std::string env_or(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::string(v) : fallback;
}

}  // namespace

bool write_report(const std::string& folder, const ReportStepOptions& options) {
  const std::string python = env_or("DSNAKE_PYTHON", "/usr/bin/python3");
  const std::string script = env_or("DSNAKE_SCRIPTS_DIR", DSNAKE_SCRIPTS_DIR) + "/report/make_report.py";
  std::vector<std::string> args = {python, script, folder};
  const std::string viewer = env_or("DSNAKE_VIEWER_JS", DSNAKE_VIEWER_JS);
  if (::access(viewer.c_str(), R_OK) == 0) args.insert(args.end(), {"--viewer", viewer});
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid == 0) {  // only async-signal-safe calls until exec
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (null_fd >= 0) ::dup2(null_fd, 0);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  std::string why;
  int status = 0;
  if (pid < 0) {
    why = std::string("fork failed: ") + std::strerror(errno);
  } else {
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return true;
    if (WIFEXITED(status) && WEXITSTATUS(status) == 127)
      why = python + " could not run " + script;
    else if (WIFEXITED(status))
      why = script + " exited with " + std::to_string(WEXITSTATUS(status));
    else
      why = script + " ended by signal " + std::to_string(WTERMSIG(status));
  }
  if (!options.quiet)
    std::fprintf(stderr, "dsnake: warning: the report of %s (report.html, the matplotlib figures) was not written: %s\n",
                 folder.c_str(), why.c_str());
  return false;
}

}  // namespace dsnake
