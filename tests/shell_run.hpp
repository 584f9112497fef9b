// Runs a shell command for the tests that drive the `atacom` executable:
// everything it writes to stdout, and its exit code (-1 if it did not exit).
#pragma once
#include <sys/wait.h>

#include <cstdio>
#include <string>

#include <catch2/catch.hpp>

struct ShellResult {
  int rc = -1;
  std::string out;
};

inline ShellResult run_shell(const std::string& cmd) {
  ShellResult r;
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p != nullptr);
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof(buf), p)) r.out.append(buf, n);
  const int status = pclose(p);
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}
