#include "app/study/spawn.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>

namespace capsflow::app::study {

pid_t spawn(std::vector<std::string> args, const SpawnOptions& options) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string output = options.output ? options.output->string() : std::string();
  const pid_t pid = fork();
  if (pid != 0) return pid;  // the parent, or -1
  if (!output.empty()) {
    const int fd = open(output.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
  }
  for (const auto& [name, value] : options.env_defaults) setenv(name.c_str(), value.c_str(), 0);
  execvp(argv[0], argv.data());
  std::fprintf(stderr, "cannot start %s\n", argv[0]);
  _exit(127);
}

int run_to_end(std::vector<std::string> args, const SpawnOptions& options) {
  const pid_t pid = spawn(std::move(args), options);
  if (pid < 0) return -1;
  int raw = 0;
  while (waitpid(pid, &raw, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

}  // namespace capsflow::app::study
