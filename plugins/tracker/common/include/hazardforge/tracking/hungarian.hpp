// Optimal assignment for rectangular cost matrices (Kuhn-Munkres with potentials), shared by the trackers.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace hf::tracking {

// Row-major cost matrix: cost[r][c]. +infinity (or NaN) marks a forbidden pair.
using CostMatrix = std::vector<std::vector<double>>;

// Minimum-cost assignment of rows to columns. Returns the (row, col) pairs of the optimal assignment that use
// only allowed entries; rows or columns left over (more rows than columns, or only forbidden partners) are
// simply absent. Among assignments, the number of allowed pairs is maximised first, then the total cost is
// minimised — forbidden entries are replaced by a cost larger than any sum of allowed costs so that they are
// only chosen when nothing allowed remains, and then dropped from the result.
inline std::vector<std::pair<int, int>> hungarian(const CostMatrix& cost) {
  const int rows = static_cast<int>(cost.size());
  if (rows == 0) return {};
  const int cols = static_cast<int>(cost[0].size());
  if (cols == 0) return {};

  // The potentials algorithm below needs n <= m; solve the transpose when there are more rows.
  const bool transposed = rows > cols;
  const int n = transposed ? cols : rows;
  const int m = transposed ? rows : cols;
  auto at = [&](int i, int j) { return transposed ? cost[j][i] : cost[i][j]; };
  auto allowed = [](double v) { return std::isfinite(v); };

  double span = 0.0;
  double lowest = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j)
      if (allowed(at(i, j))) {
        span = std::max(span, std::abs(at(i, j)));
        lowest = std::min(lowest, at(i, j));
      }
  const double forbidden = (span + 1.0) * (n + 1) * 2.0 - lowest;

  // a[i][j] 1-based; u, v potentials; p[j] = row matched to column j; way = augmenting path.
  std::vector<std::vector<double>> a(n + 1, std::vector<double>(m + 1, 0.0));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) a[i + 1][j + 1] = allowed(at(i, j)) ? at(i, j) : forbidden;

  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0);
  std::vector<int> p(m + 1, 0), way(m + 1, 0);
  for (int i = 1; i <= n; ++i) {
    p[0] = i;
    int j0 = 0;
    std::vector<double> minv(m + 1, inf);
    std::vector<char> used(m + 1, 0);
    do {
      used[j0] = 1;
      const int i0 = p[j0];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= m; ++j) {
        if (used[j]) continue;
        const double cur = a[i0][j] - u[i0] - v[j];
        if (cur < minv[j]) {
          minv[j] = cur;
          way[j] = j0;
        }
        if (minv[j] < delta) {
          delta = minv[j];
          j1 = j;
        }
      }
      for (int j = 0; j <= m; ++j) {
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      }
      j0 = j1;
    } while (p[j0] != 0);
    do {
      const int j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0 != 0);
  }

  std::vector<std::pair<int, int>> out;
  for (int j = 1; j <= m; ++j) {
    if (p[j] == 0) continue;
    const int i = p[j] - 1;
    const int c = j - 1;
    const int r = transposed ? c : i;
    const int col = transposed ? i : c;
    if (allowed(cost[r][col])) out.emplace_back(r, col);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace hf::tracking
