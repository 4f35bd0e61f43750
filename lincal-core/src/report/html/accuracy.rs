//! The accuracy map: where the calibration can be trusted. The predicted 1σ tip uncertainty
//!
//! `σ(q) = √tr(J_p·Σ_p·J_pᵀ)`  (`J_p = ∂x/∂p` exact, from the chain; `Σ_p` the estimate's
//! covariance),
//!
//! the RMS of the 3-D tip error the estimate's own uncertainty leaves at joints `q` (the
//! figure `lincal compensate` reports per target), swept along each joint's whole range with
//! the other joints at the data's median pose; the range the data covered is shaded, so a
//! user sees how fast the uncertainty grows beyond it. Takes the model, poses and estimate;
//! gives the sweeps, and the plot's SVG with its caption.

use plotters::prelude::*;

use super::plot::{house_mesh, svg, DrawResult, AFTER};
use crate::calibrate::estimate::Estimate;
use crate::data::Poses;
use crate::model::CalibModel;

/// Samples per joint's sweep.
const SAMPLES: usize = 61;
/// The most poses `σ` is evaluated at for the figures over the data (evenly spaced).
const MAX_DATA_POSES: usize = 2_000;

/// One joint's sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct JointSweep {
    /// `q1`, `q2`, ...
    pub name: String,
    /// Metres (prismatic) or radians.
    pub prismatic: bool,
    /// The joint's values swept.
    pub values: Vec<f64>,
    /// `σ` at each, metres.
    pub sigma: Vec<f64>,
    /// The smallest and largest value the data held.
    pub covered: [f64; 2],
}

/// The accuracy map of a calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct AccuracyMap {
    /// One sweep per joint.
    pub joints: Vec<JointSweep>,
    /// `σ` over the data's poses: median and largest, metres.
    pub at_data: [f64; 2],
    /// Whether the full covariance was used (else the standard deviations alone).
    pub full: bool,
}

/// The covariance of the estimated parameters (model order), row-major: the estimate's full
/// matrix when it has one, else `diag(std²)`; and whether it was the full one.
fn covariance(model: &dyn CalibModel, est: &Estimate) -> (Vec<f64>, bool) {
    let np = model.param_count();
    let mut cov = vec![0.0; np * np];
    let index = |name: &str| (0..np).find(|&j| model.param_name(j) == name);
    if let Some(c) = &est.covariance {
        let idx: Vec<Option<usize>> = c.params.iter().map(|n| index(n)).collect();
        for (a, row) in c.matrix.iter().enumerate() {
            for (b, &x) in row.iter().enumerate() {
                if let (Some(Some(i)), Some(Some(j))) = (idx.get(a), idx.get(b)) {
                    cov[i * np + j] = if x.is_finite() { x } else { 0.0 };
                }
            }
        }
        return (cov, true);
    }
    for p in est.params.iter().filter(|p| !p.known) {
        if let (Some(j), Some(s)) = (index(&p.name), p.std.filter(|s| s.is_finite())) {
            cov[j * np + j] = s * s;
        }
    }
    (cov, false)
}

/// `σ(q)` with the buffers of one model.
struct SigmaAt<'a> {
    model: &'a dyn CalibModel,
    p: &'a [f64],
    cov: Vec<f64>,
    tip: Vec<f64>,
    jac: Vec<f64>,
}

impl SigmaAt<'_> {
    fn at(&mut self, q: &[f64]) -> f64 {
        let (dim, np) = (self.model.dim(), self.p.len());
        self.model
            .tip_jacobian(q, self.p, &mut self.tip, &mut self.jac);
        let mut trace = 0.0;
        for i in 0..dim {
            let row = &self.jac[i * np..(i + 1) * np];
            for (a, ja) in row.iter().enumerate() {
                if *ja == 0.0 {
                    continue;
                }
                let c = &self.cov[a * np..(a + 1) * np];
                trace += ja * row.iter().zip(c).map(|(jb, s)| jb * s).sum::<f64>();
            }
        }
        trace.max(0.0).sqrt()
    }
}

/// The median of `v` (sorted in place); NaN when empty.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The range swept for joint `j`: its limits, else a revolute joint's full turn, else the
/// data's range widened by half its width (at least 0.1 m) on each side.
fn sweep_range(model: &dyn CalibModel, j: usize, covered: [f64; 2]) -> [f64; 2] {
    if let Some(l) = model.joint_limits(j) {
        return [l[0].min(covered[0]), l[1].max(covered[1])];
    }
    if !model.joint_is_prismatic(j) {
        return [
            covered[0].min(-std::f64::consts::PI),
            covered[1].max(std::f64::consts::PI),
        ];
    }
    let pad = (0.5 * (covered[1] - covered[0])).max(0.1);
    [covered[0] - pad, covered[1] + pad]
}

/// The accuracy map at the estimate's values `p` (the free parameters, model order); `None`
/// without poses or without any standard deviation.
#[must_use]
pub fn accuracy_map(
    model: &dyn CalibModel,
    poses: &Poses,
    est: &Estimate,
    p: &[f64],
) -> Option<AccuracyMap> {
    let (n, np, dim) = (model.joint_count(), model.param_count(), model.dim());
    if poses.q.is_empty() || n == 0 || p.len() != np {
        return None;
    }
    let (cov, full) = covariance(model, est);
    if cov.iter().all(|&c| c == 0.0) {
        return None;
    }
    let mut s = SigmaAt {
        model,
        p,
        cov,
        tip: vec![0.0; dim],
        jac: vec![0.0; dim * np],
    };
    let stride = poses.q.len().div_ceil(MAX_DATA_POSES);
    let mut data: Vec<f64> = poses.q.iter().step_by(stride).map(|q| s.at(q)).collect();
    let largest = data.iter().copied().fold(0.0, f64::max);
    let at_data = [median(&mut data), largest];
    let mut centre = vec![0.0; n];
    let mut joints = Vec::with_capacity(n);
    let mut covered_all = Vec::with_capacity(n);
    for (j, c) in centre.iter_mut().enumerate() {
        let mut v: Vec<f64> = poses.q.iter().map(|q| q[j]).collect();
        let covered = [
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ];
        *c = median(&mut v);
        covered_all.push(covered);
    }
    for (j, &covered) in covered_all.iter().enumerate() {
        let [lo, hi] = sweep_range(model, j, covered);
        let values: Vec<f64> = (0..SAMPLES)
            .map(|i| lo + (hi - lo) * i as f64 / (SAMPLES - 1) as f64)
            .collect();
        let mut q = centre.clone();
        let sigma = values
            .iter()
            .map(|&v| {
                q[j] = v;
                s.at(&q)
            })
            .collect();
        joints.push(JointSweep {
            name: format!("q{}", j + 1),
            prismatic: model.joint_is_prismatic(j),
            values,
            sigma,
            covered,
        });
    }
    Some(AccuracyMap {
        joints,
        at_data,
        full,
    })
}

/// One panel per joint (σ in µm against the joint's value, the covered range shaded); and the
/// caption.
pub(crate) fn accuracy_plot(map: &AccuracyMap) -> (Result<String, String>, String) {
    let cols = 3usize.min(map.joints.len()).max(1);
    let rows = map.joints.len().div_ceil(cols);
    let top = map
        .joints
        .iter()
        .flat_map(|j| j.sigma.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        * 1e6;
    if top <= 0.0 {
        return (Err("no finite uncertainty".to_string()), String::new());
    }
    let plot = svg((960, 260 * rows as u32), |root| -> DrawResult {
        let areas = root.split_evenly((rows, cols));
        for (area, j) in areas.iter().zip(&map.joints) {
            let (lo, hi) = (j.values[0], j.values[j.values.len() - 1]);
            let mut chart = ChartBuilder::on(area)
                .margin(8)
                .caption(&j.name, ("sans-serif", 15))
                .x_label_area_size(32)
                .y_label_area_size(56)
                .build_cartesian_2d(lo..hi, 0.0..top * 1.08)?;
            let unit = if j.prismatic { "m" } else { "rad" };
            house_mesh(
                &mut chart.configure_mesh(),
                format!("{} ({unit})", j.name),
                "σ (µm)",
            )
            .x_labels(5)
            .y_labels(5)
            .draw()?;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(j.covered[0], 0.0), (j.covered[1], top * 1.08)],
                AFTER.mix(0.12).filled(),
            )))?;
            chart.draw_series(LineSeries::new(
                j.values.iter().zip(&j.sigma).map(|(x, s)| (*x, s * 1e6)),
                AFTER.stroke_width(2),
            ))?;
        }
        Ok(())
    });
    let caption = format!(
        "The calibration's predicted 1σ tip uncertainty σ = √tr(J_p Σ_p J_pᵀ) (the RMS 3-D \
         tip error its own uncertainty leaves), along each joint's range with the other joints \
         at the data's median pose; shaded: the range the data covered. Over the data's poses \
         σ is {:.3} µm (median), {:.3} µm at most. {}",
        map.at_data[0] * 1e6,
        map.at_data[1] * 1e6,
        if map.full {
            "Σ_p is the estimate's full covariance."
        } else {
            "Σ_p is diag(std²): correlations left out (the fit gave no full covariance)."
        }
    );
    (plot, caption)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::SymbolicModel;

    /// A planar 2-link arm whose lengths alone are estimated: `∂x/∂a_i` are unit vectors, so
    /// with `Σ = diag(s₁², s₂²)` the uncertainty is `√(s₁² + s₂² + 2 s₁₂ cos q₂)` with the
    /// covariance `s₁₂` (the two unit vectors meet at angle `q₂`).
    #[test]
    fn sigma_of_a_planar_arm_is_exact() {
        let spec = crate::spec::from_yaml_str(
            "name: two\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: 0}\n  \
             - {type: revolute, a: a2, home: 0}\nparams:\n  a1: {nominal: 0.4}\n  \
             a2: {nominal: 0.3}\n  px: {nominal: 0.5}\n  py: {nominal: 0.1}\n\
             constraint:\n  point: {p: [px, py]}\n",
            None,
        )
        .unwrap();
        let model = SymbolicModel::for_fitting(&spec, 1000).unwrap();
        let names: Vec<&str> = (0..model.param_count())
            .map(|j| model.param_name(j))
            .collect();
        assert_eq!(names, ["a1", "a2", "px", "py"]);
        let (s1, s2, s12) = (2e-5, 3e-5, 1e-10);
        let mut cov = vec![0.0; 16];
        cov[0] = s1 * s1;
        cov[5] = s2 * s2;
        cov[1] = s12;
        cov[4] = s12;
        let p = [0.4, 0.3, 0.5, 0.1];
        let mut s = SigmaAt {
            model: &model,
            p: &p,
            cov,
            tip: vec![0.0; 2],
            jac: vec![0.0; 8],
        };
        for q in [[0.3f64, -1.2], [2.0, 0.4], [-1.0, 2.9]] {
            let want = (s1 * s1 + s2 * s2 + 2.0 * s12 * q[1].cos()).sqrt();
            let got = s.at(&q);
            assert!((got - want).abs() < 1e-15, "{got} vs {want}");
        }
    }
}
