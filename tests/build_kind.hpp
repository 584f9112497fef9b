// What kind of build the tests run in, for the checks whose expected bits
// were recorded by one compiler on one instruction set (golden hashes,
// evaluator fixtures) and for the allocation counter, which the sanitizers'
// own allocator replaces.
#pragma once

// GCC defines __SANITIZE_ADDRESS__; clang 14 only answers __has_feature.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define ATACOM_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define ATACOM_TEST_SANITIZED 1
#endif
#endif
#ifndef ATACOM_TEST_SANITIZED
#define ATACOM_TEST_SANITIZED 0
#endif

// The committed constants come from GCC builds; clang (which also defines
// __GNUC__) contracts and vectorises differently.
#if defined(__GNUC__) && !defined(__clang__)
#define ATACOM_TEST_GCC 1
#else
#define ATACOM_TEST_GCC 0
#endif

// The sanitizer build runs the fast tests again for memory and UB errors, at
// 20-50x the cost per step: the statistical and round-trip tests whose loops
// dominate CI take a quarter of their workload there (the same code paths).
constexpr int sanitizer_scaled(int n, int divisor = 4) { return ATACOM_TEST_SANITIZED ? n / divisor : n; }
