// 64-byte aligned vectors and row-major Eigen views on them: every buffer
// the tape, Adam and the learned distance fields compute on (core, so
// kernels and train share it).
#pragma once
#include <cstddef>
#include <cstdint>
#include <new>
#include <vector>

#include <Eigen/Core>

namespace atacom {

template <class T>
using RowMat = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
// A (rows x cols) block of a row-major buffer with leading dimension ld.
template <class T>
using MatMap = Eigen::Map<RowMat<T>, Eigen::Unaligned, Eigen::OuterStride<>>;
template <class T>
using CMatMap = Eigen::Map<const RowMat<T>, Eigen::Unaligned, Eigen::OuterStride<>>;

// Allocator giving 64-byte aligned storage. Eigen's kernels may take
// different (equally valid) code paths for differently aligned data, which
// changes rounding; aligning every buffer the tape computes on makes results
// independent of where the heap happened to place it.
template <class T, size_t Align = 64>
struct AlignedAllocator {
  using value_type = T;
  template <class U> struct rebind { using other = AlignedAllocator<U, Align>; };
  AlignedAllocator() = default;
  template <class U> AlignedAllocator(const AlignedAllocator<U, Align>&) {}
  T* allocate(size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(Align))); }
  void deallocate(T* p, size_t) { ::operator delete(p, std::align_val_t(Align)); }
  template <class U> bool operator==(const AlignedAllocator<U, Align>&) const { return true; }
  template <class U> bool operator!=(const AlignedAllocator<U, Align>&) const { return false; }
};
template <class T>
using AlignedVector = std::vector<T, AlignedAllocator<T>>;

inline bool is_aligned64(const void* p) { return (reinterpret_cast<uintptr_t>(p) & 63u) == 0; }

}  // namespace atacom
