#include "player/sim/sparse_cholesky.h"

#include <cholmod.h>
#include <omp.h>

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "common/assert.h"
#include "player/sim/lanes.h"

namespace fissure::sim {

namespace {

/// Runs CHOLMOD's OpenMP regions on the calling thread alone, for the scope's lifetime.
///
/// Debian 12's CHOLMOD (3.0.14) asks for 4 OpenMP threads in its supernodal factorization
/// whatever the machine has. On 2 cores, with the step's TBB workers awake as well, waking them
/// cost 5-6x the arithmetic: one factorization of the 10,024-tet bunny cage took 246 ms with
/// them, 38 ms without (OMP_THREAD_LIMIT=1, same run). A step's parallelism is TBB's, so
/// CHOLMOD runs serial. max-active-levels is a per-thread ICV in libgomp, so this touches
/// only the calling thread and leaves a host application's own OpenMP use alone.
class SerialOpenMpScope {
 public:
  SerialOpenMpScope() : m_saved_levels(omp_get_max_active_levels()) { omp_set_max_active_levels(0); }
  ~SerialOpenMpScope() { omp_set_max_active_levels(m_saved_levels); }
  SerialOpenMpScope(const SerialOpenMpScope&) = delete;
  SerialOpenMpScope& operator=(const SerialOpenMpScope&) = delete;

 private:
  int m_saved_levels;
};

/// A CHOLMOD view of A's lower triangle (no copy).
cholmod_sparse view_lower(const Eigen::SparseMatrix<double>& A) {
  FISSURE_ASSERT(A.isCompressed());
  cholmod_sparse view{};
  view.nrow = static_cast<std::size_t>(A.rows());
  view.ncol = static_cast<std::size_t>(A.cols());
  view.nzmax = static_cast<std::size_t>(A.nonZeros());
  view.p = const_cast<int*>(A.outerIndexPtr());
  view.i = const_cast<int*>(A.innerIndexPtr());
  view.x = const_cast<double*>(A.valuePtr());
  view.stype = -1;
  view.itype = CHOLMOD_INT;
  view.xtype = CHOLMOD_REAL;
  view.dtype = CHOLMOD_DOUBLE;
  view.sorted = 1;
  view.packed = 1;
  return view;
}

/// A supernodal factor's structure, as CHOLMOD leaves it: supernode s holds columns
/// super[s] … super[s+1]−1 of L as a dense block of pi[s+1] − pi[s] rows (the
/// diagonal block's rows first, then the rows `rows[pi[s] + ncols …]` below it),
/// values from offset px[s].
struct Supernodes {
  int count = 0;
  const int* super = nullptr;
  const int* pi = nullptr;
  const int* px = nullptr;
  const int* rows = nullptr;
};

// L Lᵀ y = c is solved in place (c already permuted) with L's values twice:
// column-major blocks (CHOLMOD's layout) for the forward sweep, row-major for the
// backward one. So both sweeps are contiguous axpys, which vectorise without
// reassociating sums, two columns (rows) at a time to halve the traffic on the work
// vector w. The summation order is fixed by the factor alone, never by the threads.

/// Forward sweep L y = c over supernodes [first, last). With `owned`, an update to a
/// row it does not mark goes to `redirected` instead of c (a second thread's private
/// sum of its updates to shared ancestors).
template <typename Value>
[[gnu::always_inline]] inline void forward_sweep(const Supernodes& L, const Value* column_major, int first, int last,
                                                 double* c, double* w, const std::uint8_t* owned,
                                                 double* redirected) {
  for (int s = first; s < last; ++s) {
    const int k1 = L.super[s], ncols = L.super[s + 1] - k1, nrows = L.pi[s + 1] - L.pi[s];
    const Value* block = column_major + L.px[s];
    const int* below = L.rows + L.pi[s] + ncols;
    for (int i = 0; i < ncols; ++i) w[i] = c[k1 + i];
    for (int i = ncols; i < nrows; ++i) w[i] = 0.0;
    int j = 0;
    for (; j + 1 < ncols; j += 2) {
      const Value* a = block + static_cast<std::ptrdiff_t>(j) * nrows;
      const Value* b = a + nrows;
      const double y0 = w[j] / static_cast<double>(a[j]);
      const double y1 = (w[j + 1] - static_cast<double>(a[j + 1]) * y0) / static_cast<double>(b[j + 1]);
      w[j] = y0;
      w[j + 1] = y1;
      for (int i = j + 2; i < nrows; ++i) w[i] -= static_cast<double>(a[i]) * y0 + static_cast<double>(b[i]) * y1;
    }
    if (j < ncols) {
      const Value* a = block + static_cast<std::ptrdiff_t>(j) * nrows;
      const double y0 = w[j] / static_cast<double>(a[j]);
      w[j] = y0;
      for (int i = j + 1; i < nrows; ++i) w[i] -= static_cast<double>(a[i]) * y0;
    }
    for (int i = 0; i < ncols; ++i) c[k1 + i] = w[i];
    for (int i = ncols; i < nrows; ++i) {
      const int row = below[i - ncols];
      (owned == nullptr || owned[row] != 0 ? c : redirected)[row] += w[i];
    }
  }
}

/// Backward sweep Lᵀ x = y over supernodes [first, last), last to first.
template <typename Value>
[[gnu::always_inline]] inline void backward_sweep(const Supernodes& L, const Value* row_major, int first, int last,
                                                  double* c, double* x) {
  for (int s = last - 1; s >= first; --s) {
    const int k1 = L.super[s], ncols = L.super[s + 1] - k1, nrows = L.pi[s + 1] - L.pi[s];
    const Value* block = row_major + L.px[s];  // element (i, j) at i * ncols + j
    const int* below = L.rows + L.pi[s] + ncols;
    for (int k = 0; k < ncols; ++k) x[k] = c[k1 + k];
    int i = ncols;
    for (; i + 1 < nrows; i += 2) {
      const Value* r0 = block + static_cast<std::ptrdiff_t>(i) * ncols;
      const Value* r1 = r0 + ncols;
      const double g0 = c[below[i - ncols]], g1 = c[below[i + 1 - ncols]];
      for (int k = 0; k < ncols; ++k) x[k] -= static_cast<double>(r0[k]) * g0 + static_cast<double>(r1[k]) * g1;
    }
    if (i < nrows) {
      const Value* r0 = block + static_cast<std::ptrdiff_t>(i) * ncols;
      const double g0 = c[below[i - ncols]];
      for (int k = 0; k < ncols; ++k) x[k] -= static_cast<double>(r0[k]) * g0;
    }
    for (int j = ncols - 1; j >= 0; --j) {
      const Value* row = block + static_cast<std::ptrdiff_t>(j) * ncols;
      const double xj = x[j] / static_cast<double>(row[j]);
      x[j] = xj;
      for (int k = 0; k < j; ++k) x[k] -= static_cast<double>(row[k]) * xj;
    }
    for (int k = 0; k < ncols; ++k) c[k1 + k] = x[k];
  }
}

// Each sweep per precision, built for AVX2/FMA and for baseline x86-64 and chosen at
// load time (the same machine always takes the same one).
#define FISSURE_SWEEPS(Value, suffix)                                                                             \
  FISSURE_SIMD_KERNEL void forward_##suffix(                             \
      const Supernodes& L, const Value* values, int first, int last, double* c, double* w,                      \
      const std::uint8_t* owned, double* redirected) {                                                            \
    forward_sweep(L, values, first, last, c, w, owned, redirected);                                               \
  }                                                                                                               \
  FISSURE_SIMD_KERNEL void backward_##suffix(                            \
      const Supernodes& L, const Value* values, int first, int last, double* c, double* x) {                      \
    backward_sweep(L, values, first, last, c, x);                                                                 \
  }
FISSURE_SWEEPS(double, double)
FISSURE_SWEEPS(float, single)
#undef FISSURE_SWEEPS

void forward(const Supernodes& L, const double* v, int first, int last, double* c, double* w,
             const std::uint8_t* owned = nullptr, double* redirected = nullptr) {
  forward_double(L, v, first, last, c, w, owned, redirected);
}
void forward(const Supernodes& L, const float* v, int first, int last, double* c, double* w,
             const std::uint8_t* owned = nullptr, double* redirected = nullptr) {
  forward_single(L, v, first, last, c, w, owned, redirected);
}
void backward(const Supernodes& L, const double* v, int first, int last, double* c, double* x) {
  backward_double(L, v, first, last, c, x);
}
void backward(const Supernodes& L, const float* v, int first, int last, double* c, double* x) {
  backward_single(L, v, first, last, c, x);
}

/// Disjoint subtrees of the supernodal elimination tree in two groups, one per thread:
/// no subtree updates another, so both groups sweep at once and only their common
/// ancestors (the rest, swept alone) see both. Each subtree is a range of supernodes in
/// CHOLMOD's postorder.
struct SubtreeSplit {
  std::vector<std::pair<int, int>> ranges[2];  ///< per thread, ascending
  std::vector<std::uint8_t> in_second;         ///< per row: a column of the second group
  std::vector<std::uint8_t> in_split;          ///< per supernode: in either group
  [[nodiscard]] bool used() const { return !ranges[0].empty() && !ranges[1].empty(); }
};

/// Below this many factor entries a solve is too short to pay for waking a thread.
constexpr double kParallelSolveMinEntries = 200'000;

/// Opens subtrees from the root down, largest first, and deals each candidate frontier
/// to two threads (largest subtree first, to the lighter thread); keeps the frontier
/// with the cheapest sweep (the rest alone, then the heavier thread). No split for a
/// small factor, or if the supernodes are not in postorder (then a subtree would not be
/// a range).
SubtreeSplit find_split(const Supernodes& L, int n) {
  const int count = L.count;
  std::vector<int> column_super(static_cast<std::size_t>(n));
  for (int s = 0; s < count; ++s) {
    for (int k = L.super[s]; k < L.super[s + 1]; ++k) column_super[k] = s;
  }
  std::vector<int> parent(count, -1), first_descendant(count), subtree_size(count, 1);
  std::vector<double> work(count, 0.0);
  double total = 0.0;
  for (int s = 0; s < count; ++s) {
    const int ncols = L.super[s + 1] - L.super[s], nrows = L.pi[s + 1] - L.pi[s];
    if (nrows > ncols) parent[s] = column_super[L.rows[L.pi[s] + ncols]];
    work[s] = static_cast<double>(nrows) * ncols;
    total += work[s];
    first_descendant[s] = s;
  }
  SubtreeSplit split;
  for (int s = 0; s < count; ++s) {  // postorder: children come before their parent
    if (parent[s] < 0) continue;
    if (parent[s] <= s) return split;
    work[parent[s]] += work[s];
    subtree_size[parent[s]] += subtree_size[s];
    first_descendant[parent[s]] = std::min(first_descendant[parent[s]], first_descendant[s]);
  }
  for (int s = 0; s < count; ++s) {
    if (s - first_descendant[s] + 1 != subtree_size[s]) return split;  // not a postorder
  }
  if (total < kParallelSolveMinEntries) return split;
  std::vector<std::vector<int>> children(count);
  std::vector<int> frontier;
  for (int s = 0; s < count; ++s) (parent[s] < 0 ? frontier : children[parent[s]]).push_back(s);
  // Deals the frontier's subtrees to two threads, largest first to the lighter one;
  // returns the solve's cost in entries: the rest alone, then the heavier thread.
  const auto deal = [&](std::vector<int> roots, SubtreeSplit* out) {
    std::sort(roots.begin(), roots.end(), [&](int a, int b) { return work[a] > work[b] || (work[a] == work[b] && a < b); });
    double load[2] = {0.0, 0.0};
    for (const int root : roots) {
      const int group = load[1] < load[0] ? 1 : 0;
      load[group] += work[root];
      if (out != nullptr) out->ranges[group].emplace_back(first_descendant[root], root + 1);
    }
    return total - load[0] - load[1] + std::max(load[0], load[1]);
  };
  // Open the largest subtree into its children (it joins the rest) while that helps;
  // keep the cheapest frontier seen.
  std::vector<int> best = frontier;
  double best_cost = deal(frontier, nullptr);
  constexpr int kMaxOpenings = 64;
  for (int opened = 0; opened < kMaxOpenings; ++opened) {
    const auto largest = std::max_element(frontier.begin(), frontier.end(), [&](int a, int b) { return work[a] < work[b]; });
    if (children[*largest].empty()) break;
    const int node = *largest;
    frontier.erase(largest);
    frontier.insert(frontier.end(), children[node].begin(), children[node].end());
    const double cost = deal(frontier, nullptr);
    if (cost < best_cost) {
      best_cost = cost;
      best = frontier;
    }
  }
  // Not worth a thread unless it saves a fifth of the sweep.
  if (best_cost > 0.8 * total) return split;
  deal(best, &split);
  split.in_second.assign(static_cast<std::size_t>(n), 0);
  split.in_split.assign(static_cast<std::size_t>(count), 0);
  for (int group = 0; group < 2; ++group) {
    std::sort(split.ranges[group].begin(), split.ranges[group].end());
    for (const auto& [first, last] : split.ranges[group]) {
      for (int s = first; s < last; ++s) split.in_split[s] = 1;
      if (group == 1) {
        for (int k = L.super[first]; k < L.super[last]; ++k) split.in_second[k] = 1;
      }
    }
  }
  return split;
}

/// Each supernode's block transposed to row-major, in `Value`.
template <typename Value>
std::vector<Value> row_major_copy(const Supernodes& L, const double* values, std::size_t size) {
  std::vector<Value> out(size);
  for (int s = 0; s < L.count; ++s) {
    const int ncols = L.super[s + 1] - L.super[s], nrows = L.pi[s + 1] - L.pi[s];
    const double* in = values + L.px[s];
    Value* block = out.data() + L.px[s];
    for (int j = 0; j < ncols; ++j) {
      for (int i = 0; i < nrows; ++i) block[static_cast<std::ptrdiff_t>(i) * ncols + j] = static_cast<Value>(in[static_cast<std::ptrdiff_t>(j) * nrows + i]);
    }
  }
  return out;
}

}  // namespace

struct SparseCholesky::Impl {
  cholmod_common common{};
  cholmod_factor* factor = nullptr;
  FactorPrecision precision = FactorPrecision::Double;
  Supernodes supernodes;
  std::size_t max_block_rows = 0;       ///< the tallest supernode (the solves' scratch)
  SubtreeSplit split;                   ///< where the solves run on two threads (if used())
  std::vector<double> double_row_major;  ///< Double: L's blocks row-major (L->x is the column-major copy)
  std::vector<float> single_column_major, single_row_major;  ///< Single: both layouts, rounded

  Impl() {
    cholmod_start(&common);
    common.supernodal = CHOLMOD_SUPERNODAL;
    common.print = 0;
    common.error_handler = nullptr;
  }
  ~Impl() {
    if (factor != nullptr) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
};

SparseCholesky::SparseCholesky() : m_impl(std::make_unique<Impl>()) {}
SparseCholesky::~SparseCholesky() = default;

void SparseCholesky::analyze(const Eigen::SparseMatrix<double>& A) {
  reset();
  cholmod_sparse view = view_lower(A);
  const SerialOpenMpScope serial;
  m_impl->factor = cholmod_analyze(&view, &m_impl->common);
  FISSURE_ASSERT(m_impl->factor != nullptr);
}

bool SparseCholesky::analyzed() const { return m_impl->factor != nullptr; }

bool SparseCholesky::factorize(const Eigen::SparseMatrix<double>& A, FactorPrecision precision) {
  FISSURE_ASSERT(analyzed());
  Impl& impl = *m_impl;
  cholmod_sparse view = view_lower(A);
  const SerialOpenMpScope serial;
  const int ok = cholmod_factorize(&view, impl.factor, &impl.common);
  m_factorized = ok != 0 && impl.common.status == CHOLMOD_OK && impl.factor->is_super != 0 &&
                 impl.factor->minor == impl.factor->n;
  impl.precision = precision;
  impl.double_row_major.clear();
  impl.single_column_major.clear();
  impl.single_row_major.clear();
  if (!m_factorized) return false;
  const cholmod_factor& L = *impl.factor;
  impl.supernodes = {static_cast<int>(L.nsuper), static_cast<const int*>(L.super), static_cast<const int*>(L.pi),
                     static_cast<const int*>(L.px), static_cast<const int*>(L.s)};
  impl.max_block_rows = 0;
  for (int s = 0; s < impl.supernodes.count; ++s) {
    impl.max_block_rows =
        std::max(impl.max_block_rows, static_cast<std::size_t>(impl.supernodes.pi[s + 1] - impl.supernodes.pi[s]));
  }
  impl.split = find_split(impl.supernodes, static_cast<int>(L.n));
  const auto* values = static_cast<const double*>(L.x);
  if (precision == FactorPrecision::Single) {
    impl.single_column_major.assign(values, values + L.xsize);
    impl.single_row_major = row_major_copy<float>(impl.supernodes, values, L.xsize);
  } else {
    impl.double_row_major = row_major_copy<double>(impl.supernodes, values, L.xsize);
  }
  return true;
}

namespace {

/// Both sweeps, over the whole factor or with the split's two groups at once.
template <typename Value>
void supernodal_solve(const Supernodes& L, const SubtreeSplit& split, std::size_t max_block_rows,
                      const Value* column_major, const Value* row_major, Eigen::VectorXd& c) {
  const auto n = c.size();
  std::vector<double> w(max_block_rows);
  if (!split.used()) {
    forward(L, column_major, 0, L.count, c.data(), w.data());
    backward(L, row_major, 0, L.count, c.data(), w.data());
    return;
  }
  // The rest (the groups' ancestors) as runs between the groups' supernodes.
  const auto for_each_rest_run = [&](auto&& sweep) {
    int s = 0;
    while (s < L.count) {
      if (split.in_split[s]) {
        ++s;
        continue;
      }
      const int first = s;
      while (s < L.count && !split.in_split[s]) ++s;
      sweep(first, s);
    }
  };
  // Forward: both groups at once. The second group's updates to rows outside its own
  // subtrees (their ancestors) go to a private vector, added after both: the sums are
  // the same for any thread count. Then the rest, in postorder.
  std::vector<double> w_second(max_block_rows);
  Eigen::VectorXd second_updates = Eigen::VectorXd::Zero(n);
  tbb::parallel_invoke(
      [&] {
        for (const auto& [first, last] : split.ranges[0]) forward(L, column_major, first, last, c.data(), w.data());
      },
      [&] {
        for (const auto& [first, last] : split.ranges[1]) {
          forward(L, column_major, first, last, c.data(), w_second.data(), split.in_second.data(),
                  second_updates.data());
        }
      });
  c += second_updates;
  for_each_rest_run([&](int first, int last) { forward(L, column_major, first, last, c.data(), w.data()); });
  // Backward: the rest from the top down, then both groups, which read only their own
  // rows and their ancestors'.
  std::vector<std::pair<int, int>> rest_runs;
  for_each_rest_run([&](int first, int last) { rest_runs.emplace_back(first, last); });
  for (auto run = rest_runs.rbegin(); run != rest_runs.rend(); ++run) {
    backward(L, row_major, run->first, run->second, c.data(), w.data());
  }
  tbb::parallel_invoke(
      [&] {
        for (auto r = split.ranges[0].rbegin(); r != split.ranges[0].rend(); ++r) {
          backward(L, row_major, r->first, r->second, c.data(), w.data());
        }
      },
      [&] {
        for (auto r = split.ranges[1].rbegin(); r != split.ranges[1].rend(); ++r) {
          backward(L, row_major, r->first, r->second, c.data(), w_second.data());
        }
      });
}

}  // namespace

void SparseCholesky::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
  FISSURE_ASSERT(m_factorized);
  const Impl& impl = *m_impl;
  const cholmod_factor& L = *impl.factor;
  const auto* perm = static_cast<const int*>(L.Perm);
  const auto n = static_cast<Eigen::Index>(L.n);
  // L Lᵀ = P A Pᵀ with (P b)[k] = b[perm[k]].
  Eigen::VectorXd c(n);
  for (Eigen::Index k = 0; k < n; ++k) c[k] = b[perm[k]];
  if (impl.precision == FactorPrecision::Single) {
    supernodal_solve(impl.supernodes, impl.split, impl.max_block_rows, impl.single_column_major.data(),
                     impl.single_row_major.data(), c);
  } else {
    supernodal_solve(impl.supernodes, impl.split, impl.max_block_rows, static_cast<const double*>(L.x),
                     impl.double_row_major.data(), c);
  }
  x.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) x[perm[k]] = c[k];
}

void SparseCholesky::reset() {
  if (m_impl->factor != nullptr) cholmod_free_factor(&m_impl->factor, &m_impl->common);
  m_impl->double_row_major.clear();
  m_impl->single_column_major.clear();
  m_impl->single_row_major.clear();
  m_factorized = false;
}

bool SparseCholesky::solves_on_two_threads() const { return m_factorized && m_impl->split.used(); }

std::size_t SparseCholesky::factor_nonzeros() const {
  // Known from the analysis: supernodal analysis fixes every supernode's block,
  // nrows × ncols, of which the upper part of the diagonal block is unused.
  if (m_impl->factor == nullptr || m_impl->factor->is_super == 0) return 0;
  const cholmod_factor& L = *m_impl->factor;
  const auto* super = static_cast<const int*>(L.super);
  const auto* pi = static_cast<const int*>(L.pi);
  std::size_t count = 0;
  for (std::size_t s = 0; s < L.nsuper; ++s) {
    const std::size_t ncols = super[s + 1] - super[s], nrows = pi[s + 1] - pi[s];
    count += nrows * ncols - ncols * (ncols - 1) / 2;
  }
  return count;
}

}  // namespace fissure::sim
