// Dense row-major 2-D tensors over our own memory.
//
// A Tensor is a view (data pointer + shape); memory comes from an Arena, a
// bump allocator over fixed chunks that never moves what it handed out. A
// training step clears the arena and allocates the same sequence again, so
// after the first step no memory is requested from the system; growth() counts
// every chunk ever allocated, which is how the tests check it.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <vector>

#include <Eigen/Core>

#include "src/core/aligned_vector.hpp"

namespace atacom {



template <class T>
struct Tensor {
  T* data = nullptr;
  int rows = 0;
  int cols = 0;
  int64_t size() const { return int64_t{rows} * cols; }
  T& operator()(int r, int c) const { return data[int64_t{r} * cols + c]; }
  MatMap<T> map() const { return MatMap<T>(data, rows, cols, Eigen::OuterStride<>(cols)); }
};

template <class T>
class Arena {
 public:
  static constexpr size_t kAlign = 64;  // one cache line, one AVX-512 vector

  explicit Arena(size_t chunk_elems = size_t{1} << 20) : chunk_elems_(chunk_elems) {}
  Arena(const Arena&) = delete;
  Arena& operator=(const Arena&) = delete;

  // n elements, 64-byte aligned, uninitialised. Valid until reset().
  T* alloc(size_t n) {
    const size_t step = kAlign / sizeof(T);
    n = (n + step - 1) / step * step;
    while (cur_ < chunks_.size()) {
      Chunk& c = chunks_[cur_];
      if (off_ + n <= c.size) {
        T* p = c.data.get() + off_;
        off_ += n;
        return p;
      }
      // The pattern of requests differs from the one the chunks were sized
      // for: insert a fitting chunk here rather than skipping memory forever.
      if (off_ == 0 && c.size < n) break;
      ++cur_;
      off_ = 0;
    }
    const size_t size = n > chunk_elems_ ? n : chunk_elems_;
    chunks_.insert(chunks_.begin() + static_cast<std::ptrdiff_t>(cur_), Chunk{make(size), size});
    ++growth_;
    off_ = n;
    return chunks_[cur_].data.get();
  }
  Tensor<T> tensor(int rows, int cols) { return Tensor<T>{alloc(size_t(rows) * size_t(cols)), rows, cols}; }

  void reset() { cur_ = 0; off_ = 0; }
  size_t growth() const { return growth_; }
  size_t capacity() const {
    size_t s = 0;
    for (const auto& c : chunks_) s += c.size;
    return s;
  }

 private:
  struct Free { void operator()(T* p) const { ::operator delete[](p, std::align_val_t(kAlign)); } };
  struct Chunk { std::unique_ptr<T[], Free> data; size_t size; };
  static std::unique_ptr<T[], Free> make(size_t n) {
    return std::unique_ptr<T[], Free>(static_cast<T*>(::operator new[](n * sizeof(T), std::align_val_t(kAlign))));
  }
  size_t chunk_elems_;
  std::vector<Chunk> chunks_;
  size_t cur_ = 0, off_ = 0;
  size_t growth_ = 0;
};

}  // namespace atacom
