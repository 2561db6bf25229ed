#include "tree_ldl.hpp"

#include <algorithm>

namespace cosserat::mj {

void factor_ldl(const mjModel* m, mjData* d, const mjtNum* M, mjtNum* LD, mjtNum* diag_inv, const char* exact) {
  const int nv = m->nv;
  const int* adr = m->dof_Madr;
  const int* parent = m->dof_parentid;
  if (LD != M) std::copy(M, M + m->nM, LD);
  for (int k = nv - 1; k >= 0; --k) {
    const int kk = adr[k];
    if (exact && exact[k] ? !(LD[kk] > 0) : LD[kk] < mjMINVAL) {
      mj_warning(d, mjWARN_INERTIA, k);
      LD[kk] = mjMINVAL;
    }
    if (m->dof_simplenum[k]) continue;
    // eliminate k from its ancestors i: row i -= t L(k, i..) with t = M(k, i) / M(k, k)
    int ki = kk + 1;
    for (int i = parent[k]; i >= 0; i = parent[i], ++ki) {
      const mjtNum t = LD[ki] / LD[kk];
      const int cnt = adr[i + 1] - adr[i];  // i < k <= nv - 1: row i's entries (i and its ancestors)
      mjtNum* __restrict row = LD + adr[i];
      const mjtNum* __restrict src = LD + ki;  // row k from column i on (rows do not overlap)
      for (int j = 0; j < cnt; ++j) row[j] += src[j] * -t;
      LD[ki] = t;
    }
  }
  for (int i = 0; i < nv; ++i) diag_inv[i] = 1.0 / LD[adr[i]];
}

void solve_ldl(const mjModel* m, const mjtNum* LD, const mjtNum* diag_inv, mjtNum* x, const mjtNum* y) {
  const int nv = m->nv;
  const int* adr = m->dof_Madr;
  const int* parent = m->dof_parentid;
  if (x != y) std::copy(y, y + nv, x);
  // x <- L^-T x (a zero entry has nothing to spread)
  for (int i = nv - 1; i >= 0; --i) {
    const mjtNum xi = x[i];
    if (m->dof_simplenum[i] || xi == 0) continue;
    int ij = adr[i] + 1;
    for (int j = parent[i]; j >= 0; j = parent[j]) x[j] -= LD[ij++] * xi;
  }
  // x <- D^-1 x
  for (int i = 0; i < nv; ++i) x[i] *= diag_inv[i];
  // x <- L^-1 x
  for (int i = 0; i < nv; ++i) {
    if (m->dof_simplenum[i]) continue;
    mjtNum xi = x[i];
    int ij = adr[i] + 1;
    for (int j = parent[i]; j >= 0; j = parent[j]) xi -= LD[ij++] * x[j];
    x[i] = xi;
  }
}

void mul_tree(const mjModel* m, const mjtNum* M, mjtNum* res, const mjtNum* vec) {
  const int nv = m->nv;
  const int* adr = m->dof_Madr;
  const int* parent = m->dof_parentid;
  for (int i = 0; i < nv; ++i) res[i] = M[adr[i]] * vec[i];
  for (int i = 0; i < nv; ++i) {
    int ij = adr[i] + 1;
    for (int j = parent[i]; j >= 0; j = parent[j], ++ij) {
      res[i] += M[ij] * vec[j];
      res[j] += M[ij] * vec[i];
    }
  }
}

}  // namespace cosserat::mj
