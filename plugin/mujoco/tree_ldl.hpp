// MuJoCo 2.2.2's sparse L^T D L factorisation of matrices in qM's layout (the kinematic tree's
// sparsity: row i holds M(i, i), M(i, parent(i)), M(i, parent(parent(i))), ... from dof_Madr[i]),
// for the implicit step's matrix A = M + h D + h^2 K (scene.cpp, factor_implicit).
//
// mj_factorI and mj_solveLD are internal in 2.2.2: mj_factorM factorises d->qM into d->qLD only,
// and mj_solveM reads only d->qLD. These are the same algorithms on caller-owned arrays, with the
// row updates inlined: mj_factorI calls mju_addToScl once per (dof, ancestor) pair, and on the
// dense dof chains of rods (n^2 / 2 pairs) the calls cost more than their arithmetic.
#pragma once

#include <mujoco/mujoco.h>

namespace cosserat::mj {

// LD (nM) and diag_inv (nv) from M (nM, qM's layout), as mj_factorM computes d->qLD and
// d->qLDiagInv from d->qM: the same operations in the same order. A diagonal below mjMINVAL is
// clamped to it with MuJoCo's mjWARN_INERTIA warning, as mj_factorM does, except on the dofs
// where `exact` (nv flags, or null) is set, whose pivots are clamped only where not positive (the
// rods' strain dofs: their inertias fall below mjMINVAL on thin, short sections). M and LD may be
// the same array.
void factor_ldl(const mjModel* m, mjData* d, const mjtNum* M, mjtNum* LD, mjtNum* diag_inv,
                const char* exact = nullptr);

// x = (L^T D L)^-1 y for one vector, as mj_solveM does with d->qLD (x and y may be the same array).
void solve_ldl(const mjModel* m, const mjtNum* LD, const mjtNum* diag_inv, mjtNum* x, const mjtNum* y);

// res = M vec for M (nM) in qM's layout, as mj_mulM does with d->qM (res and vec distinct).
void mul_tree(const mjModel* m, const mjtNum* M, mjtNum* res, const mjtNum* vec);

}  // namespace cosserat::mj
