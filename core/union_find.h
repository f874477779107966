#pragma once
// Disjoint sets over 0..n-1 with path halving; the smallest index of a set is its root, so the
// result does not depend on the order of the unions (deterministic component labels).
#include <algorithm>
#include <numeric>
#include <vector>

namespace authalic {

struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(int n) : parent(static_cast<std::size_t>(n)) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace authalic
