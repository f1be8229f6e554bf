// Items 0..n-1 grouped by an integer key, each group in item order: a counting sort, O(n +
// keys), stable, so the same grouping for any thread count. Used for the particles by cell,
// the unknowns by their cell's rank and the elimination tree's children by parent.
#pragma once

#include <numeric>
#include <vector>

namespace iqmpm {

// The items of key k are items[start[k] .. start[k + 1]); an item whose key is negative is
// left out. Keys must lie below `keys`.
struct Buckets {
  std::vector<int> start, items;
};

inline Buckets bucket_by_key(const std::vector<int>& key, int keys) {
  Buckets b;
  b.start.assign(keys + 1, 0);
  for (int k : key)
    if (k >= 0) ++b.start[k + 1];
  std::partial_sum(b.start.begin(), b.start.end(), b.start.begin());
  b.items.resize(b.start[keys]);
  std::vector<int> next(b.start.begin(), b.start.end() - 1);
  for (int item = 0; item < int(key.size()); ++item)
    if (key[item] >= 0) b.items[next[key[item]]++] = item;
  return b;
}

}  // namespace iqmpm
