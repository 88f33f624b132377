//! The fundamental equation, assembly of consistent states, and drift projection.
//!
//! ```text
//! a  = M⁻¹ f                               unconstrained acceleration
//! v̇  = a + M^-½ (A M^-½)⁺ (b − A a)        Udwadia–Kalaba
//! ```
//!
//! The pseudoinverse solve `x = B⁺ r` with `B = A M^-½` (m × n) takes a Cholesky path
//! `x = Bᵀ (B Bᵀ)⁻¹ r` when B has full row rank (well conditioned), and an SVD with a
//! relative rank tolerance otherwise, so redundant constraints and rank-deficient poses
//! are ordinary events.

pub mod dop853;
pub mod integrator;
pub mod simulate;

use crate::diag::Result;
use crate::failure::Failure;
use crate::linalg::{CHOL_TOL, Envelope, amax};
pub use crate::linalg::{RANK_TOL, all_finite, pinv_solve};
use crate::system::{System, Workspace};
use nalgebra::{DMatrix, DVector};

/// Scratch space for the dynamics of one system on one thread.
#[derive(Debug, Clone)]
pub struct DynWorkspace {
    pub sys: Workspace,
    /// A (m × n)
    pub a: DMatrix<f64>,
    /// b (m)
    pub b: DVector<f64>,
    /// B = A M^-½ (m × n)
    bm: DMatrix<f64>,
    /// B Bᵀ (m × m)
    gram: DMatrix<f64>,
    /// f (n)
    f: DVector<f64>,
    /// a = M⁻¹ f (n)
    acc: DVector<f64>,
    /// r (m)
    r: DVector<f64>,
    /// How many solves took the SVD path.
    pub svd_solves: usize,
    /// The sparse path: A W Aᵀ in envelope storage and the entries of each column of A.
    gram_env: Envelope,
    col_entries: Vec<Vec<(usize, usize)>>,
    /// Planar models: A's entries that are not zero at every pose
    /// ([`System::structural_zeros`]), in block order: (index into the values by blocks,
    /// column, row).
    nz: Vec<[u32; 3]>,
    /// Planar models: `nz`'s values weighted by M⁻¹, A_ij / m_j (per right-hand side).
    wvals: Vec<f64>,
    /// Planar models: the products that make A M⁻¹ Aᵀ, (index into `wvals`, index into
    /// the values by blocks), grouped by envelope entry in storage order; within an
    /// entry, in the order of `col_entries` without the structural zeros.
    gram_plan: Vec<[u32; 2]>,
    /// Planar models: where each envelope entry's products end in `gram_plan`.
    gram_ends: Vec<u32>,
    /// Planar models: `nz`'s indices grouped by column (in block order within a column),
    /// and where each column's end, for M⁻¹ Aᵀ y.
    col_plan: Vec<u32>,
    col_ends: Vec<u32>,
    y: Vec<f64>,
    /// A projection's correction (nv).
    dq: Vec<f64>,
    /// Spatial models: M⁻¹ at the current pose by groups of velocities.
    minv: MassInverse,
}

/// Below this reciprocal condition number of a body's angles' mass matrix, a simulation
/// stops ([`Failure::SingularMass`]): the rotation sequence is within ~1e-4 rad of its
/// singular pose, where its angle rates grow without bound.
pub const MIN_RCOND: f64 = 1e-8;

/// The inverse of a spatial model's mass matrix by groups: each translation alone
/// (1/m), each body's rotational velocities together (the inverse of `J_bᵀ I J_b` for an
/// angle sequence, updated per pose; of the inertia tensor for a free body).
#[derive(Debug, Clone, Default)]
pub struct MassInverse {
    /// (first velocity, size, offset into `vals`) of each group.
    groups: Vec<(usize, usize, usize)>,
    /// Row-major inverses.
    vals: Vec<f64>,
    /// The worst conditioned body's angles at the last update: (body, reciprocal
    /// condition number of its angles' mass matrix). Angle sequences only: a free body's
    /// block is its constant inertia tensor, checked when the model is compiled.
    pub worst: Option<(usize, f64)>,
    tmp: Vec<f64>,
}

impl MassInverse {
    fn new(sys: &System) -> MassInverse {
        let mut groups = Vec::new();
        let mut v0 = 0;
        for g in sys.geoms3() {
            for i in 0..3 {
                groups.push((g.voff + i, 1, v0));
                v0 += 1;
            }
            let n = g.nrot();
            if n > 0 {
                groups.push((g.voff + 3, n, v0));
                v0 += n * n;
            }
        }
        MassInverse {
            groups,
            vals: vec![0.0; v0],
            worst: None,
            tmp: vec![0.0; sys.nv()],
        }
    }

    /// M⁻¹ at q.
    pub fn update(&mut self, sys: &System, q: &[f64]) {
        let mut gi = 0;
        self.worst = None;
        for (k, (b, g)) in sys.bodies.iter().zip(sys.geoms3()).enumerate() {
            for _ in 0..3 {
                let v0 = self.groups[gi].2;
                self.vals[v0] = 1.0 / b.mass;
                gi += 1;
            }
            let n = g.nrot();
            if n == 0 {
                continue;
            }
            let v0 = self.groups[gi].2;
            gi += 1;
            let mut m = [0.0; 9];
            sys.rotational_mass(b, g, q, &mut m);
            let (inv, rcond) = small_spd_inverse(&m, n);
            if !g.free && self.worst.is_none_or(|(_, r)| rcond < r) {
                self.worst = Some((k, rcond));
            }
            self.vals[v0..v0 + n * n].copy_from_slice(&inv[..n * n]);
        }
    }

    /// out = M⁻¹ x.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        for &(c0, n, v0) in &self.groups {
            for i in 0..n {
                let mut s = 0.0;
                for j in 0..n {
                    s += self.vals[v0 + i * n + j] * x[c0 + j];
                }
                out[c0 + i] = s;
            }
        }
    }

    /// M^-½ (dense, symmetric) at the last update.
    fn inv_sqrt(&self, nv: usize) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(nv, nv);
        for &(c0, n, v0) in &self.groups {
            let m = DMatrix::from_row_slice(n, n, &self.vals[v0..v0 + n * n]);
            let e = crate::linalg::symmetric_eigen_or_nan(m);
            let r = e.eigenvectors.clone()
                * DMatrix::from_diagonal(&e.eigenvalues.map(|x| x.max(0.0).sqrt()))
                * e.eigenvectors.transpose();
            out.view_mut((c0, c0), (n, n)).copy_from(&r);
        }
        out
    }
}

impl DynWorkspace {
    /// The worst conditioned angle sequence at the last right-hand side: (body, the
    /// reciprocal condition number of its angles' mass matrix).
    pub fn worst_mass(&self) -> Option<(usize, f64)> {
        self.minv.worst
    }

    pub fn new(sys: &System) -> Self {
        let (m, n) = (sys.m(), sys.nv());
        let col_entries = column_entries(sys);
        let minv = MassInverse::new(sys);
        let gram_env = if sys.spatial {
            gram_envelope(sys.m(), &group_entries(&col_entries, &minv))
        } else {
            gram_envelope(sys.m(), &col_entries)
        };
        let plan = if sys.spatial {
            Plan::default()
        } else {
            nonzero_plan(sys, &col_entries, &gram_env)
        };
        DynWorkspace {
            wvals: vec![0.0; plan.nz.len()],
            nz: plan.nz,
            gram_plan: plan.gram,
            gram_ends: plan.gram_ends,
            col_plan: plan.cols,
            col_ends: plan.col_ends,
            minv,
            sys: Workspace::new(sys),
            a: DMatrix::zeros(m, n),
            b: DVector::zeros(m),
            bm: DMatrix::zeros(m, n),
            gram: DMatrix::zeros(m, m),
            f: DVector::zeros(n),
            acc: DVector::zeros(n),
            r: DVector::zeros(m),
            svd_solves: 0,
            gram_env,
            col_entries,
            y: vec![0.0; m],
            dq: vec![0.0; n],
        }
    }
}

/// For each column of A: its entries as (row, index into the values by blocks).
fn column_entries(sys: &System) -> Vec<Vec<(usize, usize)>> {
    let mut cols = vec![Vec::new(); sys.nv()];
    for b in sys.blocks() {
        for r in 0..b.rows {
            for (ci, &j) in b.cols.iter().enumerate() {
                cols[j].push((b.row0 + r, b.val0 + r * b.cols.len() + ci));
            }
        }
    }
    cols
}

/// The flat plans of the planar constraint solve (see [`nonzero_plan`]).
#[derive(Default)]
struct Plan {
    nz: Vec<[u32; 3]>,
    gram: Vec<[u32; 2]>,
    gram_ends: Vec<u32>,
    cols: Vec<u32>,
    col_ends: Vec<u32>,
}

/// A's entries that are not zero at every pose, in block order (`DynWorkspace::nz`), and
/// the products of A M⁻¹ Aᵀ for a diagonal M over them, in the order [`weighted_solve`]
/// once looped over `col_entries`: for each column j and each pair of its entries (row
/// ra ≥ rb or the other way): the envelope entry, the first entry's index in the list,
/// the second's index into the values. The structural zeros (a revolute's x row along y,
/// about a third of a planar joint's entries) are left out: every sum they entered starts
/// at +0, and adding ±0 to it changes nothing, so the numbers are the same bits.
///
/// The products are then grouped by envelope entry, each entry's in that order, so that
/// each entry is summed in a register from +0 and stored once: the same additions in the
/// same order as adding them one by one into a cleared envelope, without a store and a
/// load between two of them. Likewise M⁻¹ Aᵀ y by column.
fn nonzero_plan(sys: &System, cols: &[Vec<(usize, usize)>], env: &Envelope) -> Plan {
    let zeros: std::collections::HashSet<(usize, usize)> =
        sys.structural_zeros().into_iter().collect();
    let mut nz = Vec::new();
    // where each value by blocks sits in `nz`
    let values = sys.blocks().iter().map(|b| b.val0 + b.rows * b.cols.len());
    let mut at = vec![None; values.max().unwrap_or(0)];
    for b in sys.blocks() {
        let nc = b.cols.len();
        for r in 0..b.rows {
            for (ci, &j) in b.cols.iter().enumerate() {
                let ia = b.val0 + r * nc + ci;
                if !zeros.contains(&(b.row0 + r, j)) {
                    at[ia] = Some(nz.len());
                    nz.push([ia, j, b.row0 + r].map(|x| x as u32));
                }
            }
        }
    }
    let mut plan = Vec::new();
    for entries in cols {
        let kept: Vec<(usize, usize, usize)> = entries
            .iter()
            .filter_map(|&(r, ia)| at[ia].map(|e| (r, ia, e)))
            .collect();
        for (k, &(ra, _, ea)) in kept.iter().enumerate() {
            for &(rb, ib, _) in &kept[..=k] {
                let (hi, lo) = if ra >= rb { (ra, rb) } else { (rb, ra) };
                plan.push((env.index(hi, lo), [ea as u32, ib as u32]));
            }
        }
    }
    let (gram, gram_ends) = grouped(env.len(), plan);
    let (cols, col_ends) = grouped(
        sys.nv(),
        nz.iter()
            .enumerate()
            .map(|(e, x)| (x[1] as usize, e as u32))
            .collect(),
    );
    Plan {
        nz,
        gram,
        gram_ends,
        cols,
        col_ends,
    }
}

/// `items` (key < `keys`, value) grouped by key, each key's values in their order (a
/// stable counting sort, linear in the model's size), and where each key's group ends.
fn grouped<T: Copy + Default>(keys: usize, items: Vec<(usize, T)>) -> (Vec<T>, Vec<u32>) {
    let mut ends = vec![0u32; keys];
    for &(k, _) in &items {
        ends[k] += 1;
    }
    let mut next = Vec::with_capacity(keys);
    let mut total = 0u32;
    for e in ends.iter_mut() {
        next.push(total);
        total += *e;
        *e = total;
    }
    let mut out = vec![T::default(); items.len()];
    for (k, v) in items {
        out[next[k] as usize] = v;
        next[k] += 1;
    }
    (out, ends)
}

/// The inverse of a symmetric n × n matrix (n ≤ 3, row-major) in closed form, and its
/// reciprocal condition number λ_min/λ_max (exact for n ≤ 2; for n = 3 the estimate
/// 1/(‖M‖_F ‖M⁻¹‖_F), within a factor 3 of it). No allocation: this runs per
/// right-hand side for every body with angles.
fn small_spd_inverse(m: &[f64; 9], n: usize) -> ([f64; 9], f64) {
    let mut inv = [0.0; 9];
    match n {
        1 => {
            inv[0] = 1.0 / m[0];
            (inv, if m[0] > 0.0 { 1.0 } else { 0.0 })
        }
        2 => {
            let (a, b, d) = (m[0], m[1], m[3]);
            let det = a * d - b * b;
            inv[0] = d / det;
            inv[1] = -b / det;
            inv[2] = -b / det;
            inv[3] = a / det;
            let (tr, disc) = (a + d, ((a - d) * (a - d) + 4.0 * b * b).sqrt());
            let (lo, hi) = ((tr - disc) / 2.0, (tr + disc) / 2.0);
            (inv, if hi > 0.0 { lo / hi } else { 0.0 })
        }
        _ => {
            let e = |i: usize, j: usize| m[3 * i + j];
            let c00 = e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1);
            let c01 = e(1, 2) * e(2, 0) - e(1, 0) * e(2, 2);
            let c02 = e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0);
            let det = e(0, 0) * c00 + e(0, 1) * c01 + e(0, 2) * c02;
            let adj = [
                c00,
                e(0, 2) * e(2, 1) - e(0, 1) * e(2, 2),
                e(0, 1) * e(1, 2) - e(0, 2) * e(1, 1),
                c01,
                e(0, 0) * e(2, 2) - e(0, 2) * e(2, 0),
                e(0, 2) * e(1, 0) - e(0, 0) * e(1, 2),
                c02,
                e(0, 1) * e(2, 0) - e(0, 0) * e(2, 1),
                e(0, 0) * e(1, 1) - e(0, 1) * e(1, 0),
            ];
            for (x, a) in inv.iter_mut().zip(adj) {
                *x = a / det;
            }
            let fro = |v: &[f64; 9]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let r = 1.0 / (fro(m) * fro(&inv));
            (inv, if det > 0.0 && r.is_finite() { r } else { 0.0 })
        }
    }
}

/// The entries of A by groups of columns that M⁻¹ couples (for the envelope).
fn group_entries(cols: &[Vec<(usize, usize)>], minv: &MassInverse) -> Vec<Vec<(usize, usize)>> {
    minv.groups
        .iter()
        .map(|&(c0, n, _)| cols[c0..c0 + n].iter().flatten().copied().collect())
        .collect()
}

/// The envelope of A W Aᵀ: row i starts at the first row sharing a column with it.
fn gram_envelope(m: usize, columns: &[Vec<(usize, usize)>]) -> Envelope {
    let mut first: Vec<usize> = (0..m).collect();
    for entries in columns {
        if let Some(lo) = entries.iter().map(|e| e.0).min() {
            for &(r, _) in entries {
                first[r] = first[r].min(lo);
            }
        }
    }
    Envelope::new(first)
}

/// Numerical rank of A M^-½ at a pose.
pub fn constraint_rank(sys: &System, q: &[f64], t: f64) -> usize {
    let mut ws = DynWorkspace::new(sys);
    sys.jacobian(&mut ws.sys, q, t, &mut ws.a);
    if sys.m() == 0 {
        return 0;
    }
    let bm = if sys.spatial {
        ws.minv.update(sys, q);
        &ws.a * ws.minv.inv_sqrt(sys.nv())
    } else {
        &ws.a * &sys.mass_inv_sqrt
    };
    if !all_finite(bm.as_slice()) {
        return 0;
    }
    let svd = crate::linalg::svd_or_nan(bm, false, false);
    let smax = svd.singular_values.max();
    svd.singular_values
        .iter()
        .filter(|&&s| s > RANK_TOL * smax)
        .count()
}

/// Accelerations v̇ from the fundamental equation at (q, v, t).
pub fn accelerations(
    sys: &System,
    ws: &mut DynWorkspace,
    q: &[f64],
    v: &[f64],
    t: f64,
    vdot: &mut [f64],
) {
    // f = impressed forces, A (by blocks) and b by automatic differentiation, sharing
    // each body's pose; a = M⁻¹ f (M diagonal)
    sys.rhs_terms(&mut ws.sys, q, v, t, ws.f.as_mut_slice(), &mut ws.b);
    if sys.spatial {
        ws.minv.update(sys, q);
        ws.minv.apply(ws.f.as_slice(), ws.acc.as_mut_slice());
    } else {
        for i in 0..ws.acc.len() {
            ws.acc[i] = sys.mass_inv_diag[i] * ws.f[i];
        }
    }
    if sys.m() == 0 {
        vdot.copy_from_slice(ws.acc.as_slice());
        return;
    }
    // r = b − A a
    for b in sys.blocks() {
        let nc = b.cols.len();
        for r in 0..b.rows {
            let row = &ws.sys.vals[b.val0 + r * nc..b.val0 + (r + 1) * nc];
            let aa: f64 = row.iter().zip(&b.cols).map(|(x, &j)| x * ws.acc[j]).sum();
            ws.r[b.row0 + r] = ws.b[b.row0 + r] - aa;
        }
    }
    // v̇ = a + M⁻¹ Aᵀ (A M⁻¹ Aᵀ)⁺ r
    weighted_solve(sys, ws, vdot);
    for i in 0..vdot.len() {
        vdot[i] += ws.acc[i];
    }
}

/// `out = M⁻¹ Aᵀ (A M⁻¹ Aᵀ)⁺ r = M^-½ (A M^-½)⁺ r` for `r = ws.r`, with A already in
/// `ws.sys.vals` by blocks: the M-weighted minimum-norm solution of A x = r.
/// Sparse path: A M⁻¹ Aᵀ from the blocks, factored by an envelope Cholesky (no
/// allocation); when a pivot is too small (A rank-deficient or ill-conditioned), the dense
/// SVD pseudoinverse.
fn weighted_solve(sys: &System, ws: &mut DynWorkspace, out: &mut [f64]) {
    if sys.spatial {
        return weighted_solve_groups(sys, ws, out);
    }
    let vals = &ws.sys.vals;
    for (w, &[ia, j, _]) in ws.wvals.iter_mut().zip(&ws.nz) {
        *w = vals[ia as usize] * sys.mass_inv_diag[j as usize];
    }
    let mut p = 0;
    for (e, &end) in ws.gram_env.values_mut().iter_mut().zip(&ws.gram_ends) {
        let mut s = 0.0;
        for &[ea, ib] in &ws.gram_plan[p..end as usize] {
            s += ws.wvals[ea as usize] * vals[ib as usize];
        }
        *e = s;
        p = end as usize;
    }
    if ws.gram_env.factor(CHOL_TOL) {
        ws.y.copy_from_slice(ws.r.as_slice());
        ws.gram_env.solve(&mut ws.y);
        // M⁻¹ Aᵀ y over A's entries that are not always zero, column by column
        let mut p = 0;
        for (o, &end) in out.iter_mut().zip(&ws.col_ends) {
            let mut s = 0.0;
            for &e in &ws.col_plan[p..end as usize] {
                s += ws.wvals[e as usize] * ws.y[ws.nz[e as usize][2] as usize];
            }
            *o = s;
            p = end as usize;
        }
        return;
    }
    // Rank-deficient or ill-conditioned: the dense pseudoinverse of B = A M^-½ (A from
    // the blocks already computed).
    sys.blocks_to_dense(&ws.sys, &mut ws.a);
    ws.a.mul_to(&sys.mass_inv_sqrt, &mut ws.bm);
    let (x, _) = pinv_solve(&ws.bm, &ws.r, &mut ws.gram, &mut ws.svd_solves);
    let corr = &sys.mass_inv_sqrt * x;
    out.copy_from_slice(corr.as_slice());
}

/// [`weighted_solve`] with M⁻¹ by groups (spatial models; `ws.minv` updated at the pose).
fn weighted_solve_groups(sys: &System, ws: &mut DynWorkspace, out: &mut [f64]) {
    ws.gram_env.clear();
    for &(c0, n, v0) in &ws.minv.groups {
        for jj in 0..n {
            for kk in 0..n {
                let w = ws.minv.vals[v0 + jj * n + kk];
                if w == 0.0 {
                    continue;
                }
                for &(ra, ia) in &ws.col_entries[c0 + jj] {
                    let wa = ws.sys.vals[ia] * w;
                    for &(rb, ib) in &ws.col_entries[c0 + kk] {
                        if ra >= rb {
                            ws.gram_env.add(ra, rb, wa * ws.sys.vals[ib]);
                        }
                    }
                }
            }
        }
    }
    if ws.gram_env.factor(CHOL_TOL) {
        ws.y.copy_from_slice(ws.r.as_slice());
        ws.gram_env.solve(&mut ws.y);
        let tmp = &mut ws.minv.tmp;
        tmp.fill(0.0);
        for b in sys.blocks() {
            let nc = b.cols.len();
            for r in 0..b.rows {
                let yr = ws.y[b.row0 + r];
                for (ci, &j) in b.cols.iter().enumerate() {
                    tmp[j] += ws.sys.vals[b.val0 + r * nc + ci] * yr;
                }
            }
        }
        let tmp = std::mem::take(&mut ws.minv.tmp);
        ws.minv.apply(&tmp, out);
        ws.minv.tmp = tmp;
        return;
    }
    sys.blocks_to_dense(&ws.sys, &mut ws.a);
    let ms = ws.minv.inv_sqrt(sys.nv());
    ws.a.mul_to(&ms, &mut ws.bm);
    let (x, _) = pinv_solve(&ws.bm, &ws.r, &mut ws.gram, &mut ws.svd_solves);
    let corr = &ms * x;
    out.copy_from_slice(corr.as_slice());
}

/// Largest |Φ| at q (on the stack up to 64 rows: it is checked at every written sample).
pub fn residual_norm(sys: &System, q: &[f64], t: f64) -> f64 {
    let m = sys.m();
    if m <= 64 {
        let mut buf = [0.0; 64];
        sys.phi(q, t, &mut buf[..m]);
        amax(&buf[..m])
    } else {
        amax(sys.residual(q, t).as_slice())
    }
}

/// Newton projection of q onto Φ(q, t) = 0 with the M-weighted minimum-norm correction
/// Δq = −M^-½ (A M^-½)⁺ Φ. Returns the final |Φ|∞.
pub fn project_position(
    sys: &System,
    ws: &mut DynWorkspace,
    q: &mut [f64],
    t: f64,
    tol: f64,
    max_iter: usize,
) -> f64 {
    // Φ in `ws.r`, the right-hand side of the solve (nothing allocated: written samples
    // are projected by this)
    sys.phi(q, t, ws.r.as_mut_slice());
    let mut norm = ws.r.amax();
    let mut dq = std::mem::take(&mut ws.dq);
    for _ in 0..max_iter {
        if norm <= tol {
            break;
        }
        sys.jacobian_blocks(&mut ws.sys, q, t);
        if sys.spatial {
            ws.minv.update(sys, q);
        }
        weighted_solve(sys, ws, &mut dq);
        sys.retract(q, &dq, -1.0);
        sys.phi(q, t, ws.r.as_mut_slice());
        let new_norm = ws.r.amax();
        if !(new_norm < norm) {
            norm = new_norm;
            break;
        }
        norm = new_norm;
    }
    ws.dq = dq;
    norm
}

/// Velocity constraint residual ψ = A v + ∂Φ/∂t.
pub fn velocity_residual(
    sys: &System,
    ws: &mut DynWorkspace,
    q: &[f64],
    v: &[f64],
    t: f64,
) -> DVector<f64> {
    sys.jacobian(&mut ws.sys, q, t, &mut ws.a);
    let mut pt = DVector::zeros(sys.m());
    sys.phi_t(&mut ws.sys, q, t, &mut pt);
    &ws.a * DVector::from_column_slice(v) + pt
}

/// Project v onto A v + Φ_t = 0 (M-weighted minimum change). Returns |ψ|∞ before.
pub fn project_velocity(
    sys: &System,
    ws: &mut DynWorkspace,
    q: &[f64],
    v: &mut [f64],
    t: f64,
) -> f64 {
    let before = velocity_residual_blocks(sys, ws, q, v, t);
    if sys.m() == 0 {
        return before;
    }
    if sys.spatial {
        ws.minv.update(sys, q);
    }
    let mut dv = std::mem::take(&mut ws.dq);
    weighted_solve(sys, ws, &mut dv);
    for i in 0..v.len() {
        v[i] -= dv[i];
    }
    ws.dq = dv;
    before
}

/// ψ = A v + ∂Φ/∂t into `ws.r`, with A by blocks (left in `ws.sys.vals`); returns |ψ|∞.
pub fn velocity_residual_blocks(
    sys: &System,
    ws: &mut DynWorkspace,
    q: &[f64],
    v: &[f64],
    t: f64,
) -> f64 {
    sys.jacobian_blocks(&mut ws.sys, q, t);
    sys.phi_t(&mut ws.sys, q, t, &mut ws.r);
    for b in sys.blocks() {
        let nc = b.cols.len();
        for r in 0..b.rows {
            let row = &ws.sys.vals[b.val0 + r * nc..b.val0 + (r + 1) * nc];
            ws.r[b.row0 + r] += row.iter().zip(&b.cols).map(|(x, &j)| x * v[j]).sum::<f64>();
        }
    }
    ws.r.amax()
}

/// The correction of the coordinates `cols` that solves A_cols Δ = r with the least
/// kinetic-energy norm Δᵀ M Δ (M's diagonal), so the result does not depend on units.
fn weighted_min_norm(
    sys: &System,
    a: &DMatrix<f64>,
    cols: &[usize],
    r: &DVector<f64>,
) -> DVector<f64> {
    if cols.is_empty() {
        // nothing to correct (every velocity given): nalgebra has no SVD of nothing
        return DVector::zeros(0);
    }
    let weights = sys.mass_weights();
    let w: Vec<f64> = cols.iter().map(|&i| weights[i]).collect();
    let mut af = a.select_columns(cols.iter());
    for (k, wk) in w.iter().enumerate() {
        af.column_mut(k).scale_mut(*wk);
    }
    if !all_finite(af.as_slice()) || !all_finite(r.as_slice()) {
        return DVector::from_element(cols.len(), f64::NAN);
    }
    let svd = crate::linalg::svd_or_nan(af, true, true);
    let eps = RANK_TOL * svd.singular_values.max().max(f64::MIN_POSITIVE);
    let y = svd
        .solve(r, eps)
        .unwrap_or_else(|_| DVector::zeros(cols.len()));
    DVector::from_iterator(cols.len(), y.iter().zip(&w).map(|(v, wk)| v * wk))
}

/// A consistent state: positions on Φ = 0, velocities on A v + Φ_t = 0.
#[derive(Debug, Clone)]
pub struct State {
    pub t: f64,
    pub q: Vec<f64>,
    pub v: Vec<f64>,
}

/// Assemble the initial state: solve Φ(q, 0) = 0 for the coordinates the model does not
/// fix, starting from its guesses (damped Gauss–Newton with minimum-norm steps), then the
/// velocities the model does not give from A v + Φ_t = 0, nearest to rest relative to the
/// ground.
pub fn assemble(sys: &System) -> Result<State> {
    let (q, mut ws) = assemble_pose(sys)?;
    let (n, t, init) = (sys.nv(), 0.0, &sys.initial);
    // Velocities: the given ones are held; the others start at rest relative to the
    // ground (which may move) and are corrected to the constraints, minimum norm.
    let mut v = init.v.clone();
    let carried = sys.ground_velocity(&q, t);
    for i in 0..n {
        if !init.v_given[i] {
            v[i] = carried[i];
        }
    }
    if sys.m() > 0 {
        let vfree: Vec<usize> = (0..n).filter(|&i| !init.v_given[i]).collect();
        let psi = velocity_residual(sys, &mut ws, &q, &v, t);
        let dv = weighted_min_norm(sys, &ws.a, &vfree, &psi);
        for (k, &i) in vfree.iter().enumerate() {
            v[i] -= dv[k];
        }
        let psi = velocity_residual(sys, &mut ws, &q, &v, t);
        let after = psi.amax();
        if after > 1e-8 * (1.0 + v.iter().fold(0.0f64, |a, x| a.max(x.abs()))) {
            return Err(inconsistent_velocities(sys, &ws.a, &psi, &v));
        }
    }
    Ok(State { t, q, v })
}

/// The initial velocities break the velocity constraints: the worst row of the residual
/// `psi`, and the given velocity that contributes most to it (|A_ri v_i|), located at its
/// entry in the model file.
fn inconsistent_velocities(
    sys: &System,
    a: &nalgebra::DMatrix<f64>,
    psi: &DVector<f64>,
    v: &[f64],
) -> crate::diag::Error {
    let row = psi.iamax();
    let blamed = (0..sys.nv())
        .filter(|&i| sys.initial.v_given[i])
        .map(|i| (i, (a[(row, i)] * v[i]).abs()))
        .filter(|&(_, c)| c > 0.0)
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(i, _)| i);
    let given = blamed.map(|i| {
        let name = &sys.velocities[i];
        let (body, velocity) = name.split_once('.').unwrap_or(("", name));
        crate::failure::GivenVelocity {
            body: body.to_string(),
            velocity: velocity.to_string(),
            value: v[i],
        }
    });
    crate::diag::Error::failed_at(
        Failure::InconsistentVelocities {
            residual: psi[row].abs(),
            constraint: sys.constraint_names[row].clone(),
            given,
        },
        blamed.and_then(|i| sys.initial_velocity_location(i)),
    )
}

/// The assembled initial pose at rest (velocities zero): what statics start from. A
/// model's given initial velocities do not matter to its equilibria and are not checked.
pub fn assemble_at_rest(sys: &System) -> Result<State> {
    let (q, _) = assemble_pose(sys)?;
    Ok(State {
        t: 0.0,
        v: vec![0.0; sys.nv()],
        q,
    })
}

/// The coordinates of the initial pose: Φ(q, 0) = 0 solved for the coordinates the model
/// does not fix, from its guesses (see [`assemble`]); the workspace, for what follows.
fn assemble_pose(sys: &System) -> Result<(Vec<f64>, DynWorkspace)> {
    let n = sys.nv();
    let init = &sys.initial;
    let mut q = init.q.clone();
    if let Some(i) = q.iter().position(|x| !x.is_finite()) {
        return Err(Failure::UndefinedGuess {
            coordinate: sys.coordinates[i].clone(),
        }
        .into());
    }
    // the tangent directions solved for (a free body's orientation is held whole)
    let (held, held_tangent) = sys.held();
    let free: Vec<usize> = (0..n).filter(|&i| !held_tangent[i]).collect();
    let mut ws = DynWorkspace::new(sys);
    let t = 0.0;
    let tol = 1e-13 * (1.0 + q.iter().fold(0.0f64, |a, x| a.max(x.abs())));
    let mut phi = sys.residual(&q, t);
    let mut norm = phi.amax();
    let mut iterations = 0;
    while norm > tol && iterations < 100 {
        iterations += 1;
        sys.jacobian(&mut ws.sys, &q, t, &mut ws.a);
        let dx = weighted_min_norm(sys, &ws.a, &free, &phi);
        // damped step: halve until |Φ| decreases
        let mut step = 1.0;
        let mut accepted = false;
        let mut delta = vec![0.0; n];
        for (k, &i) in free.iter().enumerate() {
            delta[i] = dx[k];
        }
        for _ in 0..30 {
            let mut trial = q.clone();
            sys.retract(&mut trial, &delta, -step);
            let p = sys.residual(&trial, t);
            if p.amax() < norm {
                q = trial;
                phi = p;
                norm = phi.amax();
                accepted = true;
                break;
            }
            step *= 0.5;
        }
        if !accepted {
            break;
        }
    }
    if let Some(i) = (0..sys.m()).find(|&i| !phi[i].is_finite()) {
        return Err(Failure::UndefinedConstraint {
            constraint: sys.constraint_names[i].clone(),
            value: phi[i],
            iterations,
        }
        .into());
    }
    if norm > 1e-9 || !norm.is_finite() {
        let worst = (0..sys.m())
            .max_by(|&i, &j| phi[i].abs().total_cmp(&phi[j].abs()))
            .map(|i| sys.constraint_names[i].clone())
            .unwrap_or_default();
        let fixed: Vec<(String, f64)> = held
            .iter()
            .map(|&i| (sys.coordinates[i].clone(), init.q[i]))
            .collect();
        return Err(Failure::NoAssembly {
            residual: norm,
            iterations,
            worst,
            fixed,
        }
        .into());
    }
    Ok((q, ws))
}
