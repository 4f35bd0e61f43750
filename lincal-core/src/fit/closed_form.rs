//! Closed-form extraction for the paper's sec. 4.1 case: a planar arm of revolute joints
//! (unknown lengths `a_i` and home offsets `θh_i`) with its tip on an unknown line
//! `b·x + 1 = 0`.
//!
//! There `h = 1 + Σ_i a_i‖b‖ [cos(γ_i)·C_{1..i} + sin(γ_i)·S_{1..i}]` with
//! `γ_i = β + θh_1 + … + θh_i`, `β = atan2(b₂, b₁)`, `C_{1..i} = cos(q_1 + … + q_i)`. From the
//! linear solution, written on those functions, `γ_i = atan2(S_i, C_i)` and
//! `a_i‖b‖ = hypot(C_i, S_i)`; with the gauge rule's `a_1` and `θh_1` at their nominals,
//! `‖b‖ = hypot_1/a_1`, `β = γ_1 − θh_1`, `θh_i = γ_i − γ_{i−1}`, `a_i = hypot_i/‖b‖`. No initial
//! guess and no iteration: the general extraction then starts from this exact point.

use crate::fit::solve::{LinearSolve, SolutionForm};
use crate::model::CalibModel;
use crate::spec::{Constraint, JointKind, Slot, Spec};
use nalgebra::DMatrix;

/// The closed-form estimate of the estimated parameters `p`, when the spec is the paper's
/// planar-arm-on-a-line case and the gauge rule holds `a_1` and `θh_1`; `None` otherwise.
#[must_use]
pub fn planar_line(spec: &Spec, model: &dyn CalibModel, lin: &LinearSolve) -> Option<Vec<f64>> {
    let (b1, b2, links) = planar_line_params(spec, model)?;
    let n = links.len();
    let group = lin.groups.first()?;
    if group.form != SolutionForm::Normalised {
        return None;
    }
    let c = group.solution.first()?;
    let d = on_angle_sums(model, n, c)?;
    let gamma: Vec<f64> = (0..n).map(|i| d[2 + 2 * i].atan2(d[1 + 2 * i])).collect();
    let mag: Vec<f64> = (0..n).map(|i| d[2 + 2 * i].hypot(d[1 + 2 * i])).collect();
    let mut p: Vec<f64> = (0..model.param_count())
        .map(|j| model.param_nominal(j))
        .collect();
    let a1 = p[links[0].0];
    if a1 <= 0.0 || mag[0] <= 0.0 {
        return None;
    }
    let norm_b = mag[0] / a1;
    let beta = gamma[0] - p[links[0].1];
    for i in 1..n {
        p[links[i].0] = mag[i] / norm_b;
        p[links[i].1] = crate::numeric::wrap_angle(gamma[i] - gamma[i - 1]);
    }
    p[b1] = norm_b * beta.cos();
    p[b2] = norm_b * beta.sin();
    p.iter().all(|v| v.is_finite()).then_some(p)
}

/// The parameter indices `(a_i, θh_i)` of each joint of the paper's planar arm.
type Links = Vec<(usize, usize)>;

/// When the spec is the paper's case (a planar arm of revolute joints with `α = 0` and no tool
/// offset, no base, one line `b`) and the gauge rule holds exactly `a_1` and `θh_1`: the
/// parameter indices of `b₁`, `b₂` and each joint's `(a_i, θh_i)`; `None` otherwise.
fn planar_line_params(spec: &Spec, model: &dyn CalibModel) -> Option<(usize, usize, Links)> {
    let index = |s: &Slot| -> Option<usize> {
        let name = s.param()?;
        (0..model.param_count()).find(|&j| model.param_name(j) == name)
    };
    if spec.dim != 2 || spec.base.is_some() || spec.constraints.len() != 1 {
        return None;
    }
    let Constraint::Line2 { b } = &spec.constraints[0] else {
        return None;
    };
    let zero = |s: &Slot| matches!(s, Slot::Const(e) if e.is_zero());
    if !spec.tool.iter().all(zero) {
        return None;
    }
    let (b1, b2) = (index(&b[0])?, index(&b[1])?);
    let mut links = Vec::new();
    for j in &spec.joints {
        if j.kind != JointKind::Revolute || !zero(&j.alpha) {
            return None;
        }
        links.push((index(&j.a)?, index(&j.home)?));
    }
    // The gauge rule must hold exactly a_1 and θh_1 for this start to be the answer.
    let held: Vec<usize> = (0..model.param_count())
        .filter(|&j| model.param_held(j))
        .collect();
    if held != {
        let mut v = vec![links[0].0, links[0].1];
        v.sort_unstable();
        v
    } {
        return None;
    }
    Some((b1, b2, links))
}

/// The linear solution `c` written on `F = (1, C_1, S_1, …, C_{1..n}, S_{1..n})` (`Φ̃ = T·F`
/// exactly for this arm, `T` fitted on deterministic joint readings) and normalised to a
/// constant of 1; `None` when the basis is not `F`'s span or the constant vanishes.
fn on_angle_sums(model: &dyn CalibModel, n: usize, c: &[f64]) -> Option<Vec<f64>> {
    // Write h = c·Φ̃ on F = (1, C_1, S_1, …, C_{1..n}, S_{1..n}): Φ̃ = T·F exactly for this arm.
    let k = model.basis_size();
    if k != 2 * n + 1 || c.len() != k {
        return None;
    }
    let m = 4 * k + 8;
    let mut f = DMatrix::zeros(m, k);
    let mut phi = DMatrix::zeros(m, k);
    let mut buf = vec![0.0; k];
    for r in 0..m {
        // Deterministic, well-spread joint readings.
        let q: Vec<f64> = (0..n)
            .map(|i| ((r * 7 + i * 13) as f64 * 0.618_033_988_75).sin() * 3.0)
            .collect();
        model.basis(&q, &mut buf);
        for (col, v) in buf.iter().enumerate() {
            phi[(r, col)] = *v;
        }
        f[(r, 0)] = 1.0;
        let mut sum = 0.0;
        for (i, qi) in q.iter().enumerate() {
            sum += qi;
            f[(r, 1 + 2 * i)] = sum.cos();
            f[(r, 2 + 2 * i)] = sum.sin();
        }
    }
    let t = crate::numeric::linalg::checked_svd(f.clone(), true, true)
        .ok()?
        .solve(&phi, 1e-12)
        .ok()?;
    if (&f * &t - &phi).norm() > 1e-9 * phi.norm().max(1.0) {
        return None;
    }
    let d = &t * DMatrix::from_column_slice(k, 1, c);
    if d[(0, 0)].abs() < f64::MIN_POSITIVE {
        return None;
    }
    let d: Vec<f64> = d.iter().map(|v| v / d[(0, 0)]).collect();
    Some(d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::SymbolicModel;
    use std::path::Path;

    /// On the shared AdeptOne case the closed form is already the extraction's answer, and
    /// it lands on the reference values.
    #[test]
    fn closed_form_is_the_extraction_on_the_paper_case() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/cases/adept_line");
        let spec = crate::spec::from_yaml_file(&dir.join("spec.yaml")).unwrap();
        let model = SymbolicModel::from_spec(&spec).unwrap();
        let poses =
            crate::data::Poses::from_csv_path(&dir.join("data.csv"), &model, false).unwrap();
        let lin = crate::fit::solve::solve(&model, &poses).unwrap();
        let start = planar_line(&spec, &model, &lin).expect("the paper's case");
        let ext = crate::fit::extract::extract(&model, &lin).unwrap();
        for (j, (a, b)) in start.iter().zip(&ext.p).enumerate() {
            assert!((a - b).abs() < 1e-8, "{}: {a} vs {b}", model.param_name(j));
        }
        // a2/a1 and θh2 against the reference implementation's values.
        assert!((start[2] / start[0] - 1.13323).abs() < 1.2e-4);
        assert!((start[3] - 0.0446).abs() < 1e-5);
    }

    #[test]
    fn other_specs_have_no_closed_form() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../lincal-models/specs");
        let spec = crate::spec::from_yaml_file(&dir.join("planar3_point.yaml")).unwrap();
        let model = SymbolicModel::from_spec(&spec).unwrap();
        let lin = crate::fit::solve::LinearSolver::new(&model)
            .unwrap()
            .finish();
        if let Ok(lin) = lin {
            assert!(planar_line(&spec, &model, &lin).is_none());
        }
    }
}
