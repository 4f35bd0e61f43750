//! Hand-coded `CalibModel`s of a planar n-link arm (paper sec. 4.1 and 4.2), independent of
//! the symbolic engine.
//!
//! Parameters `p = [a1, th1, …, an, thn, u, v]` with `(u, v)` = `(b1, b2)` for a line,
//! `(px, py)` for a pinned point, `(bx, by)` (base offset) for a measured tip.
//! Basis `[C1, S1, C12, S12, …, 1]` (cumulative joint sums), `K = 2n + 1`.

use lincal_core::calibrate::SpecParam;
use lincal_core::model::geometry::ConstraintKind;
use lincal_core::CalibModel;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Line,
    Point,
    Measured,
}

pub struct PlanarArm {
    pub n: usize,
    pub kind: Kind,
    pub nominal: Vec<f64>,
    names: Vec<String>,
    basis_names: Vec<String>,
    chain: Vec<lincal_core::model::chain::Factor>,
}

impl PlanarArm {
    pub fn new(n: usize, kind: Kind, nominal: Vec<f64>) -> Self {
        let mut names = Vec::new();
        for i in 1..=n {
            names.push(format!("a{i}"));
            names.push(format!("th{i}"));
        }
        let extra = match kind {
            Kind::Line => ["b1", "b2"],
            Kind::Point => ["px", "py"],
            Kind::Measured => ["bx", "by"],
        };
        names.extend(extra.iter().map(|s| (*s).to_string()));
        assert_eq!(nominal.len(), names.len());
        let mut basis_names = Vec::new();
        for i in 1..=n {
            basis_names.push(format!("C1..{i}"));
            basis_names.push(format!("S1..{i}"));
        }
        basis_names.push("1".into());
        // The same arm as elementary motions: the measured tip's offset, then per link
        // Rz(q_i − th_i)·Tx(a_i).
        use lincal_core::model::chain::{Axis, Factor, Term};
        let motion = |rotation, axis, joint, param, coef| Factor {
            rotation,
            axis,
            constant: 0.0,
            joint,
            terms: [Some(Term { param, coef }), None],
        };
        let mut chain = Vec::new();
        if kind == Kind::Measured {
            chain.push(motion(false, Axis::X, None, 2 * n, 1.0));
            chain.push(motion(false, Axis::Y, None, 2 * n + 1, 1.0));
        }
        for i in 0..n {
            chain.push(motion(true, Axis::Z, Some(i), 2 * i + 1, -1.0));
            chain.push(motion(false, Axis::X, None, 2 * i, 1.0));
        }
        PlanarArm {
            n,
            kind,
            nominal,
            names,
            basis_names,
            chain,
        }
    }

    pub fn spec_params(&self) -> Vec<SpecParam> {
        self.names
            .iter()
            .zip(&self.nominal)
            .map(|(n, &v)| SpecParam {
                name: n.clone(),
                nominal: v,
                known: false,
            })
            .collect()
    }

    pub fn index(&self, name: &str) -> usize {
        self.names.iter().position(|n| n == name).unwrap()
    }

    /// X and Y coefficient vectors (length K, constant 0) and their derivatives
    /// `dX[k][j]` over all parameters.
    #[allow(clippy::type_complexity)]
    fn xy(&self, p: &[f64]) -> (Vec<f64>, Vec<f64>, Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let k = 2 * self.n + 1;
        let np = p.len();
        let (mut x, mut y) = (vec![0.0; k], vec![0.0; k]);
        let (mut dx, mut dy) = (vec![vec![0.0; np]; k], vec![vec![0.0; np]; k]);
        let mut h = 0.0;
        for i in 0..self.n {
            let a = p[2 * i];
            h += p[2 * i + 1];
            let (s, c) = h.sin_cos();
            x[2 * i] = a * c;
            x[2 * i + 1] = a * s;
            y[2 * i] = -a * s;
            y[2 * i + 1] = a * c;
            dx[2 * i][2 * i] = c;
            dx[2 * i + 1][2 * i] = s;
            dy[2 * i][2 * i] = -s;
            dy[2 * i + 1][2 * i] = c;
            for m in 0..=i {
                let t = 2 * m + 1;
                dx[2 * i][t] = -a * s;
                dx[2 * i + 1][t] = a * c;
                dy[2 * i][t] = -a * c;
                dy[2 * i + 1][t] = -a * s;
            }
        }
        (x, y, dx, dy)
    }
}

impl CalibModel for PlanarArm {
    fn name(&self) -> &str {
        "planar_arm"
    }
    fn dim(&self) -> usize {
        2
    }
    fn joint_count(&self) -> usize {
        self.n
    }
    fn joint_is_prismatic(&self, _i: usize) -> bool {
        false
    }
    fn joint_limits(&self, _i: usize) -> Option<[f64; 2]> {
        Some([-2.8, 2.8])
    }
    fn param_count(&self) -> usize {
        self.names.len()
    }
    fn param_name(&self, j: usize) -> &str {
        &self.names[j]
    }
    fn param_nominal(&self, j: usize) -> f64 {
        self.nominal[j]
    }
    fn param_is_angle(&self, j: usize) -> bool {
        j < 2 * self.n && j % 2 == 1
    }
    fn param_identifiable(&self, j: usize) -> bool {
        match self.kind {
            Kind::Measured => true,
            _ => j < 2 * self.n && j % 2 == 1 && j > 1,
        }
    }
    fn param_held(&self, j: usize) -> bool {
        self.kind != Kind::Measured && j < 2
    }
    fn identifiable_count(&self) -> usize {
        match self.kind {
            Kind::Measured => 2 * self.n + 2,
            _ => 2 * self.n,
        }
    }
    fn basis_size(&self) -> usize {
        2 * self.n + 1
    }
    fn basis_name(&self, k: usize) -> &str {
        &self.basis_names[k]
    }
    fn constant_index(&self) -> Option<usize> {
        Some(2 * self.n)
    }
    fn constraint_count(&self) -> usize {
        1
    }
    fn constraint_kind(&self, _j: usize) -> ConstraintKind {
        match self.kind {
            Kind::Line => ConstraintKind::Line2,
            Kind::Point => ConstraintKind::Point,
            Kind::Measured => ConstraintKind::Measured,
        }
    }
    fn constraint_values(&self, _j: usize, p: &[f64], out: &mut [f64]) {
        if self.kind != Kind::Measured {
            out[0] = p[2 * self.n];
            out[1] = p[2 * self.n + 1];
        }
    }
    fn equation_count(&self) -> usize {
        if self.kind == Kind::Line {
            1
        } else {
            2
        }
    }
    fn equation_constraint(&self, _e: usize) -> usize {
        0
    }
    fn basis(&self, q: &[f64], out: &mut [f64]) {
        let mut t = 0.0;
        for i in 0..self.n {
            t += q[i];
            out[2 * i] = t.cos();
            out[2 * i + 1] = t.sin();
        }
        out[2 * self.n] = 1.0;
    }
    fn generalized_params(&self, p: &[f64], out: &mut [f64]) {
        let k = 2 * self.n + 1;
        let (x, y, _, _) = self.xy(p);
        let (u, v) = (p[2 * self.n], p[2 * self.n + 1]);
        match self.kind {
            Kind::Line => {
                for kk in 0..k {
                    out[kk] = u * x[kk] + v * y[kk];
                }
                out[k - 1] = 1.0;
            }
            Kind::Point | Kind::Measured => {
                let sign = if self.kind == Kind::Point { -1.0 } else { 1.0 };
                out[..k].copy_from_slice(&x);
                out[k..2 * k].copy_from_slice(&y);
                out[k - 1] = sign * u;
                out[2 * k - 1] = sign * v;
            }
        }
    }
    fn jacobian(&self, p: &[f64], out: &mut [f64]) {
        let k = 2 * self.n + 1;
        let np = p.len();
        let (x, y, dx, dy) = self.xy(p);
        let (iu, iv) = (2 * self.n, 2 * self.n + 1);
        let (u, v) = (p[iu], p[iv]);
        out.iter_mut().for_each(|o| *o = 0.0);
        match self.kind {
            Kind::Line => {
                for kk in 0..k {
                    for j in 0..np {
                        out[kk * np + j] = u * dx[kk][j] + v * dy[kk][j];
                    }
                    out[kk * np + iu] = x[kk];
                    out[kk * np + iv] = y[kk];
                }
            }
            Kind::Point | Kind::Measured => {
                let sign = if self.kind == Kind::Point { -1.0 } else { 1.0 };
                for kk in 0..k {
                    for j in 0..np {
                        out[kk * np + j] = dx[kk][j];
                        out[(k + kk) * np + j] = dy[kk][j];
                    }
                }
                out[(k - 1) * np + iu] = sign;
                out[(2 * k - 1) * np + iv] = sign;
            }
        }
    }
    fn tip(&self, q: &[f64], p: &[f64], out: &mut [f64]) {
        let (mut x, mut y) = (0.0, 0.0);
        if self.kind == Kind::Measured {
            x = p[2 * self.n];
            y = p[2 * self.n + 1];
        }
        let (mut t, mut h) = (0.0, 0.0);
        for i in 0..self.n {
            t += q[i];
            h += p[2 * i + 1];
            x += p[2 * i] * (t - h).cos();
            y += p[2 * i] * (t - h).sin();
        }
        out[0] = x;
        out[1] = y;
    }
    fn tip_jacobian(&self, q: &[f64], p: &[f64], tip: &mut [f64], jac: &mut [f64]) {
        // x = Σ a_i cos(t_i − H_i), y = Σ a_i sin(t_i − H_i), t and H cumulative sums.
        self.tip(q, p, tip);
        let np = p.len();
        jac[..2 * np].iter_mut().for_each(|v| *v = 0.0);
        let (mut t, mut h) = (0.0, 0.0);
        let mut angles = Vec::with_capacity(self.n);
        for i in 0..self.n {
            t += q[i];
            h += p[2 * i + 1];
            angles.push(t - h);
        }
        for i in 0..self.n {
            let (s, c) = angles[i].sin_cos();
            jac[2 * i] = c;
            jac[np + 2 * i] = s;
            // H_i includes h_k for k ≤ i.
            for k in 0..=i {
                jac[2 * k + 1] += p[2 * i] * s;
                jac[np + 2 * k + 1] -= p[2 * i] * c;
            }
        }
        if self.kind == Kind::Measured {
            jac[2 * self.n] = 1.0;
            jac[np + 2 * self.n + 1] = 1.0;
        }
    }
    fn constraint_value_param(&self, _j: usize, v: usize) -> Option<usize> {
        (self.kind != Kind::Measured).then_some(2 * self.n + v)
    }
    fn chain(&self) -> &[lincal_core::model::chain::Factor] {
        &self.chain
    }
}

/// Checks the model's analytic Jacobian against central differences and `c(p)·Φ̃(q)`
/// against the constraint function of the tip.
pub fn self_check(model: &dyn CalibModel, p: &[f64], q: &[f64]) {
    use lincal_core::model::geometry::constraint_function;
    let k = model.basis_size();
    let e = model.equation_count();
    let np = model.param_count();
    let mut c = vec![0.0; e * k];
    model.generalized_params(p, &mut c);
    let mut phi = vec![0.0; k];
    model.basis(q, &mut phi);
    let mut tip = vec![0.0; model.dim()];
    model.tip(q, p, &mut tip);
    let kind = model.constraint_kind(0);
    let mut vals = vec![0.0; kind.value_count(model.dim())];
    model.constraint_values(0, p, &mut vals);
    let mut h = vec![0.0; e];
    constraint_function(kind, model.dim(), &vals, &tip, &mut h);
    for ee in 0..e {
        let lin: f64 = (0..k).map(|kk| c[ee * k + kk] * phi[kk]).sum();
        assert!(
            (lin - h[ee]).abs() < 1e-12,
            "equation {ee}: {lin} vs {}",
            h[ee]
        );
    }
    let mut jac = vec![0.0; e * k * np];
    model.jacobian(p, &mut jac);
    for j in 0..np {
        let hh = 1e-6;
        let mut pp = p.to_vec();
        pp[j] += hh;
        let mut cp = vec![0.0; e * k];
        model.generalized_params(&pp, &mut cp);
        pp[j] -= 2.0 * hh;
        let mut cm = vec![0.0; e * k];
        model.generalized_params(&pp, &mut cm);
        for i in 0..e * k {
            let fd = (cp[i] - cm[i]) / (2.0 * hh);
            assert!((fd - jac[i * np + j]).abs() < 1e-7, "dc[{i}]/dp[{j}]");
        }
    }
}
