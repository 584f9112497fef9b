// The libFuzzer entry point every target in this directory defines. Built
// with clang -fsanitize=fuzzer (ATACOM_FUZZ=ON) libFuzzer drives it; in any
// other build replay_main.cpp feeds it the committed corpus, so the gcc
// build and its sanitizer build replay every input as a [fast] ctest test.
// A target calls fuzz_fail() for a broken contract (a lost answer, an
// exception that is not an input error): it aborts, which both drivers count
// as a crash.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
// Optional (weak): a target's one-time setup and its own flags.
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc, char*** argv);

[[noreturn]] inline void fuzz_fail(const char* what, const char* detail = "") {
  std::fprintf(stderr, "fuzz target contract broken: %s %s\n", what, detail);
  std::abort();
}
