#pragma once
// A monotone priority queue of (key, value) pairs with 32-bit keys: a radix heap. Keys pushed must
// not be smaller than the last key taken out (true of Dijkstra-like searches, where a neighbour's
// key is never below the key being expanded). Push is O(1); taking the smallest is O(1) amortized
// plus O(32) to find the next non-empty bucket: bucket b holds keys whose highest bit differing
// from the last minimum is bit b - 1 (bucket 0: keys equal to it).
#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace handson {

template <class Value>
class RadixQueue {
 public:
  using Entry = std::pair<std::uint32_t, Value>;

  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }
  void clear() {
    for (auto& b : buckets_) b.clear();
    size_ = 0;
    last_ = 0;
  }
  /// key >= the last key taken (or peeked) out.
  void push(std::uint32_t key, Value v) {
    buckets_[bucket(key)].push_back({key, v});
    ++size_;
  }
  /// The entry with the smallest key (the queue must not be empty).
  const Entry& top() {
    assert(size_ > 0);
    settle();
    return buckets_[0].back();
  }
  void pop() {
    assert(size_ > 0);
    settle();
    buckets_[0].pop_back();
    --size_;
  }

 private:
  std::size_t bucket(std::uint32_t key) const { return key == last_ ? 0 : std::size_t(32 - std::countl_zero(key ^ last_)); }
  // Makes bucket 0 hold the smallest key: the first non-empty bucket's minimum becomes the new
  // reference, and that bucket's entries move to lower buckets.
  void settle() {
    if (!buckets_[0].empty()) return;
    std::size_t b = 1;
    while (buckets_[b].empty()) ++b;
    std::uint32_t smallest = buckets_[b].front().first;
    for (const auto& e : buckets_[b]) smallest = std::min(smallest, e.first);
    last_ = smallest;
    std::vector<Entry> moving;
    moving.swap(buckets_[b]);
    for (const auto& e : moving) buckets_[bucket(e.first)].push_back(e);
    moving.clear();
    if (buckets_[b].empty()) buckets_[b].swap(moving);  // keep the capacity
  }

  std::array<std::vector<Entry>, 33> buckets_;
  std::size_t size_ = 0;
  std::uint32_t last_ = 0;
};

}  // namespace handson
