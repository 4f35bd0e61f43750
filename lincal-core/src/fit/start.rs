//! Starts from the data, not from guesses: the values of unknown constraints (a socket's
//! point, a plane, a sphere, a circle, a line, a quadric) fitted to the tips of the **nominal**
//! arm before any fit runs.
//!
//! A constraint's values are replaced only when every one of them is an estimated parameter
//! that moves no joint of the chain (a fixture's own coordinates) and that the gauge rule does
//! not hold (a held value fixes a representation, as the two planes of a 3-D line), or, for a
//! point (coordinates fitted each on its own) or a sphere or circle whose centre is free
//! (a ball bar's known radius keeps its value), those of them that are; the
//! constraint has enough
//! poses, and the fit is well posed; otherwise the spec's nominals stay (the fallback). The
//! fits, per kind, on the nominal tips `x_l` of the constraint's poses:
//! - point: the mean `x̄`;
//! - plane (line in the plane): the total-least-squares plane through `x̄` with normal `n` the
//!   scatter matrix's eigenvector of least eigenvalue, written `b = −n/(n·x̄)` (kept only when
//!   the plane stays clear of the origin, `|n·x̄|` above 10⁻⁶ of the tips' reach);
//! - plane by normal (`n·x = d`): the same plane as `(n̂, n̂·x̄)` with `n̂` of unit length, any
//!   plane (also through the origin). Its values need not all be free: the fitted `(n̂, d̂)`
//!   is scaled by the `λ` that best matches the fixed normal entries (numbers, known or held
//!   parameters; the offset when the normal has none that can set it), or with none fixed
//!   turned to the side of the nominal normal, and only the free values are set; a fully
//!   fixed normal `n` gets just its offset, `d = n·x̄`. See [`plane_normal_start`];
//! - 3-D line: the two planes through `x̄` normal to the scatter's two least eigenvectors;
//! - sphere, circle: the algebraic (Kåsa) fit `‖x‖² + D·x + E = 0`, centre `−D/2`, radius
//!   `√(‖D/2‖² − E)`;
//! - quadric: the linear least-squares fit of `xᵀAx + bᵀx + 1 = 0`.
//!
//! [`DataStart`] is the model seen by the fits: the same model whose nominal values of those
//! parameters are the fitted ones. Two starts that would coincide (two points of a
//! `distance` relation both at the import's nominal) are thus apart whenever their poses are.

use nalgebra::{DMatrix, DVector};

use crate::data::Poses;
use crate::model::chain::Factor;
use crate::model::geometry::{ConstraintKind, Relation};
use crate::model::{CalibModel, PriorRows};

/// Start values of `model`'s parameters: the nominals, with each unknown constraint fitted to
/// the nominal arm's tips of its poses (see the module docs). Also gives which constraints got
/// a fitted start.
#[must_use]
pub fn constraint_start(model: &dyn CalibModel, poses: &Poses) -> (Vec<f64>, Vec<usize>) {
    let np = model.param_count();
    let mut p: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    let in_chain = chain_params(model.chain(), np);
    let mut fitted = Vec::new();
    for j in 0..model.constraint_count() {
        if model.constraint_kind(j) == ConstraintKind::PlaneNormal {
            let tips = nominal_tips(model, poses, j, &p);
            if let Some(set) = plane_normal_start(model, j, &in_chain, &tips, &p) {
                for (slot, value) in set {
                    p[slot] = value;
                }
                fitted.push(j);
            }
            continue;
        }
        let Some(slots) = own_slots(model, j, &in_chain) else {
            continue;
        };
        let tips = nominal_tips(model, poses, j, &p);
        let kind = model.constraint_kind(j);
        let Some(v) = fit_values(kind, model.dim(), &tips) else {
            continue;
        };
        // A parameter in two slots (a quadric's symmetric A) takes one value: both must agree.
        let consistent = slots.iter().enumerate().all(|(a, s)| {
            s.is_none()
                || slots[..a]
                    .iter()
                    .position(|t| t == s)
                    .is_none_or(|b| (v[a] - v[b]).abs() <= 1e-12 * v[a].abs().max(v[b].abs()))
        });
        if consistent && v.iter().all(|x| x.is_finite()) {
            for (slot, value) in slots.iter().zip(v) {
                if let Some(slot) = slot {
                    p[*slot] = value;
                }
            }
            fitted.push(j);
        }
    }
    (p, fitted)
}

/// Whether each estimated parameter moves a joint of the chain.
fn chain_params(chain: &[Factor], np: usize) -> Vec<bool> {
    let mut used = vec![false; np];
    for t in chain.iter().flat_map(|f| f.terms.iter().flatten()) {
        if let Some(u) = used.get_mut(t.param) {
            *u = true;
        }
    }
    used
}

/// The parameters behind constraint `j`'s values, in value order, each `Some` when the fit
/// may set it: an estimated parameter outside the chain that the gauge rule does not hold.
/// Every value must be such a parameter, except for a point, whose coordinates are fitted
/// each on its own (a socket on a known plane), and a sphere or a circle with a free centre
/// and a fixed radius (a ball bar's known length): there the fixed values keep theirs and
/// the others are fitted. `None` when nothing may be set.
fn own_slots(model: &dyn CalibModel, j: usize, in_chain: &[bool]) -> Option<Vec<Option<usize>>> {
    let kind = model.constraint_kind(j);
    let n = kind.value_count(model.dim());
    if n == 0 {
        return None;
    }
    // A value the gauge rule holds stays at its nominal: the hold fixes a representation
    // (which two planes carry a 3-D line), and the other values are fitted around it.
    let slots: Vec<Option<usize>> = (0..n)
        .map(|v| {
            model
                .constraint_value_param(j, v)
                .filter(|&s| !in_chain.get(s).copied().unwrap_or(true) && !model.param_held(s))
        })
        .collect();
    let any = slots.iter().any(Option::is_some);
    let all = slots.iter().all(Option::is_some);
    // A point's coordinates are each the mean of theirs. A sphere's (circle's) centre comes
    // from the fit with any radius; its radius only with the fitted centre, so the centre
    // must be free for a fixed radius to be left out, not the other way round.
    let separable = match kind {
        ConstraintKind::Point => any,
        ConstraintKind::Sphere | ConstraintKind::Circle => {
            slots[..n - 1].iter().all(Option::is_some)
        }
        _ => false,
    };
    (all || separable).then_some(slots)
}

/// The start of a plane by normal `n·x = d` (constraint `j`, kind
/// [`ConstraintKind::PlaneNormal`]) from the nominal tips: `(slot, value)` for each value that
/// is an estimated parameter outside the chain and not held (see the module docs); `None`
/// (the nominals stay) when none is, the fit is ill-posed, or the values disagree.
///
/// The plane `(n̂, d̂)` is known up to the scale `λ`: with `F` the fixed normal entries,
/// `λ = Σ_F f_k n̂_k / Σ_F n̂_k²` (or from a fixed offset, `λ = d/d̂`, when `F` cannot set it),
/// with nothing fixed `λ = ±1` towards the nominal normal.
#[must_use]
pub fn plane_normal_start(
    model: &dyn CalibModel,
    j: usize,
    in_chain: &[bool],
    tips: &[[f64; 3]],
    p: &[f64],
) -> Option<Vec<(usize, f64)>> {
    let slots: Vec<Option<usize>> = (0..4).map(|v| model.constraint_value_param(j, v)).collect();
    let free: Vec<bool> = slots
        .iter()
        .map(|s| {
            s.is_some_and(|s| !in_chain.get(s).copied().unwrap_or(true) && !model.param_held(s))
        })
        .collect();
    if !free.contains(&true) || tips.is_empty() {
        return None;
    }
    let mut cur = [0.0; 4];
    model.constraint_values(j, p, &mut cur);
    let v = if free[..3].contains(&true) {
        let fit = fit_values(ConstraintKind::PlaneNormal, 3, tips)?;
        let lambda = plane_scale(&fit, &cur, &free)?;
        fit.iter().map(|x| lambda * x).collect::<Vec<f64>>()
    } else {
        let n = tips.len() as f64;
        let d = (0..3)
            .map(|i| cur[i] * tips.iter().map(|x| x[i]).sum::<f64>() / n)
            .sum();
        vec![cur[0], cur[1], cur[2], d]
    };
    let mut set: Vec<(usize, f64)> = Vec::new();
    for k in (0..4).filter(|&k| free[k]) {
        let (slot, value) = (slots[k]?, v[k]);
        // A name in two slots takes one value: both must agree.
        if let Some(&(_, w)) = set.iter().find(|(s, _)| *s == slot) {
            if (w - value).abs() > 1e-12 * w.abs().max(value.abs()) {
                return None;
            }
        }
        set.push((slot, value));
    }
    v.iter().all(|x| x.is_finite()).then_some(set)
}

/// The scale `λ` of a fitted `(n̂, d̂)` that best matches the fixed values of `cur` (see
/// [`plane_normal_start`]); `None` when it is zero or not finite.
fn plane_scale(fit: &[f64], cur: &[f64; 4], free: &[bool]) -> Option<f64> {
    let fixed = |ks: core::ops::Range<usize>| -> (f64, f64) {
        ks.filter(|&k| !free[k]).fold((0.0, 0.0), |(a, b), k| {
            (a + cur[k] * fit[k], b + fit[k] * fit[k])
        })
    };
    let (num, den) = fixed(0..3);
    let lambda = if den > 1e-6 {
        num / den
    } else if !free[3] && fit[3].abs() > 1e-9 && cur[3] != 0.0 {
        cur[3] / fit[3]
    } else {
        let toward: f64 = (0..3).map(|k| fit[k] * cur[k]).sum();
        if toward < 0.0 {
            -1.0
        } else {
            1.0
        }
    };
    (lambda.is_finite() && lambda != 0.0).then_some(lambda)
}

/// Most poses a start is fitted to: a start needs no more, and a million poses then cost a
/// few milliseconds and no memory to speak of.
pub const START_POSES: usize = 4096;

/// The tips at `p` of constraint `j`'s poses, at most [`START_POSES`] of them evenly spread.
fn nominal_tips(model: &dyn CalibModel, poses: &Poses, j: usize, p: &[f64]) -> Vec<[f64; 3]> {
    let dim = model.dim();
    let count = poses.constraint.iter().filter(|&c| c == j).count();
    let stride = count.div_ceil(START_POSES).max(1);
    let mut out = Vec::with_capacity(count.min(START_POSES));
    let of_j = (0..poses.len()).filter(|&l| poses.constraint.at(l) == j);
    for l in of_j.step_by(stride) {
        let mut x = [0.0; 3];
        model.tip(&poses.q[l], p, &mut x[..dim]);
        out.push(x);
    }
    out
}

/// The values of a constraint of `kind` fitted to `tips` (see the module docs), in the
/// canonical value order of [`ConstraintKind`]; `None` when too few tips or ill-posed.
#[must_use]
pub fn fit_values(kind: ConstraintKind, dim: usize, tips: &[[f64; 3]]) -> Option<Vec<f64>> {
    let n = tips.len();
    if n == 0 {
        return None;
    }
    let mean: [f64; 3] =
        core::array::from_fn(|i| tips.iter().map(|x| x[i]).sum::<f64>() / n as f64);
    match kind {
        ConstraintKind::Point => Some(mean[..dim].to_vec()),
        ConstraintKind::Plane | ConstraintKind::Line2 => {
            let (vals, vecs) = scatter_eigen(tips, &mean, dim, dim + 1)?;
            // The plane's normal: the least spread; a degenerate pencil (two least equal)
            // has no unique plane.
            if vals[1] <= 1e-12 * vals[dim - 1].max(f64::MIN_POSITIVE) {
                return None;
            }
            plane_through(&vecs[0], &mean, dim, tips)
        }
        ConstraintKind::PlaneNormal => {
            let (vals, vecs) = scatter_eigen(tips, &mean, 3, 4)?;
            if vals[1] <= 1e-12 * vals[2].max(f64::MIN_POSITIVE) {
                return None;
            }
            // The unit normal with its largest entry positive, and d = n·x̄.
            let n = &vecs[0];
            let big = n
                .iter()
                .copied()
                .fold(0.0f64, |a, x| if x.abs() > a.abs() { x } else { a });
            let s = if big < 0.0 { -1.0 } else { 1.0 };
            let mut v: Vec<f64> = n.iter().map(|x| s * x).collect();
            v.push((0..3).map(|i| v[i] * mean[i]).sum());
            Some(v)
        }
        ConstraintKind::Line3 => {
            let (vals, vecs) = scatter_eigen(tips, &mean, 3, 3)?;
            if vals[2] <= 0.0 {
                return None;
            }
            let mut v = plane_through(&vecs[0], &mean, 3, tips)?;
            v.extend(plane_through(&vecs[1], &mean, 3, tips)?);
            Some(v)
        }
        ConstraintKind::Circle | ConstraintKind::Sphere => kasa(tips, dim),
        ConstraintKind::Quadric => quadric(tips, dim),
        ConstraintKind::Measured | ConstraintKind::MeasuredPose => None,
    }
}

/// Eigenvalues (ascending) and eigenvectors of the tips' scatter about `mean` in `dim`
/// coordinates, when there are at least `need` tips.
fn scatter_eigen(
    tips: &[[f64; 3]],
    mean: &[f64; 3],
    dim: usize,
    need: usize,
) -> Option<(Vec<f64>, Vec<Vec<f64>>)> {
    if tips.len() < need {
        return None;
    }
    let mut s = DMatrix::<f64>::zeros(dim, dim);
    for x in tips {
        let u = DVector::from_iterator(dim, (0..dim).map(|i| x[i] - mean[i]));
        s += &u * u.transpose();
    }
    let e = s.try_symmetric_eigen(f64::EPSILON, 1000)?;
    let mut order: Vec<usize> = (0..dim).collect();
    order.sort_by(|&a, &b| e.eigenvalues[a].total_cmp(&e.eigenvalues[b]));
    let vals = order.iter().map(|&i| e.eigenvalues[i]).collect();
    let vecs = order
        .iter()
        .map(|&i| e.eigenvectors.column(i).iter().copied().collect())
        .collect();
    Some((vals, vecs))
}

/// The plane (line) with unit normal `n` through `mean` as `b = −n/(n·mean)`, or `None`
/// when it passes (nearly) through the origin, where that form does not exist.
fn plane_through(n: &[f64], mean: &[f64; 3], dim: usize, tips: &[[f64; 3]]) -> Option<Vec<f64>> {
    let d: f64 = (0..dim).map(|i| n[i] * mean[i]).sum();
    let reach = tips
        .iter()
        .map(|x| (0..dim).map(|i| x[i] * x[i]).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    (d.abs() > 1e-6 * reach.max(f64::MIN_POSITIVE)).then(|| (0..dim).map(|i| -n[i] / d).collect())
}

/// The Kåsa fit of a circle (sphere): `‖x‖² + D·x + E = 0` by linear least squares; values
/// `[centre…, radius]`.
fn kasa(tips: &[[f64; 3]], dim: usize) -> Option<Vec<f64>> {
    if tips.len() < dim + 2 {
        return None;
    }
    let a = DMatrix::from_fn(
        tips.len(),
        dim + 1,
        |l, c| {
            if c < dim {
                tips[l][c]
            } else {
                1.0
            }
        },
    );
    let y = DVector::from_iterator(
        tips.len(),
        tips.iter()
            .map(|x| -(0..dim).map(|i| x[i] * x[i]).sum::<f64>()),
    );
    let sol = least_squares(&a, &y)?;
    let centre: Vec<f64> = (0..dim).map(|i| -sol[i] / 2.0).collect();
    let r2 = centre.iter().map(|c| c * c).sum::<f64>() - sol[dim];
    (r2 > 0.0).then(|| {
        let mut v = centre;
        v.push(r2.sqrt());
        v
    })
}

/// The linear least-squares quadric `xᵀAx + bᵀx + 1 = 0` (`A` symmetric), values `A`
/// row-major then `b`.
fn quadric(tips: &[[f64; 3]], dim: usize) -> Option<Vec<f64>> {
    let pairs: Vec<(usize, usize)> = (0..dim)
        .flat_map(|i| (i..dim).map(move |k| (i, k)))
        .collect();
    let unknowns = pairs.len() + dim;
    if tips.len() < 2 * unknowns {
        return None;
    }
    let a = DMatrix::from_fn(tips.len(), unknowns, |l, c| {
        let x = &tips[l];
        match pairs.get(c) {
            Some(&(i, k)) if i == k => x[i] * x[i],
            Some(&(i, k)) => 2.0 * x[i] * x[k],
            None => x[c - pairs.len()],
        }
    });
    let y = DVector::from_element(tips.len(), -1.0);
    let sol = least_squares(&a, &y)?;
    let mut m = vec![0.0; dim * dim];
    for (c, &(i, k)) in pairs.iter().enumerate() {
        m[i * dim + k] = sol[c];
        m[k * dim + i] = sol[c];
    }
    m.extend((0..dim).map(|i| sol[pairs.len() + i]));
    Some(m)
}

/// `argmin ‖A x − y‖` by SVD, `None` when `A` loses rank (relative 10⁻¹⁰).
fn least_squares(a: &DMatrix<f64>, y: &DVector<f64>) -> Option<DVector<f64>> {
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if !(smax > 0.0 && smin > 1e-10 * smax) {
        return None;
    }
    svd.solve(y, 0.0).ok()
}

/// `model` seen with other nominal values (the data-driven start of [`constraint_start`]):
/// every other answer is `model`'s.
#[derive(Clone)]
pub struct DataStart<'a> {
    model: &'a dyn CalibModel,
    nominal: Vec<f64>,
    /// [`CalibModel::prior`] (`None`: `model`'s own).
    prior: Option<std::sync::Arc<OwnedPrior>>,
    /// [`CalibModel::orientation_weight`] (`None`: `model`'s own).
    orientation: Option<f64>,
    /// Parameters held beside `model`'s own ([`DataStart::without_constraints`]); empty:
    /// none.
    held: Vec<bool>,
    /// [`CalibModel::relations`] (`None`: `model`'s own).
    relations: Option<Vec<Relation>>,
    /// The identifiability of the constraints with poses ([`DataStart::without_constraints`];
    /// `None`: `model`'s own).
    gauge: Option<std::sync::Arc<crate::model::DataGauge>>,
}

impl<'a> DataStart<'a> {
    /// `model` with the start of [`constraint_start`] on `poses` as its nominals.
    #[must_use]
    pub fn new(model: &'a dyn CalibModel, poses: &Poses) -> DataStart<'a> {
        let (nominal, _) = constraint_start(model, poses);
        DataStart {
            model,
            nominal,
            prior: None,
            orientation: None,
            held: Vec::new(),
            relations: None,
            gauge: None,
        }
    }

    /// `model` as it is (its own nominals), to carry other weights.
    #[must_use]
    pub fn plain(model: &'a dyn CalibModel) -> DataStart<'a> {
        DataStart {
            model,
            nominal: (0..model.param_count())
                .map(|j| model.param_nominal(j))
                .collect(),
            prior: None,
            orientation: None,
            held: Vec::new(),
            relations: None,
            gauge: None,
        }
    }

    /// The same model for a fit that sees no pose of the constraints marked `unseen` (a
    /// cross-validation fold that holds out whole placements): their own values (parameters
    /// no joint and no seen constraint uses) held at their nominals, and the relations that
    /// involve them left out. Such a value and its relations say nothing the fit's poses can
    /// check (the relation is met by moving the unseen value alone), so the fit determines
    /// what its poses determine, no more and no less; the held-out placement's values are
    /// refitted on its own poses afterwards.
    #[must_use]
    pub fn without_constraints(&self, unseen: &[bool]) -> DataStart<'a> {
        let np = self.model.param_count();
        let mut used = chain_params(self.model.chain(), np);
        let values = |j: usize| {
            let n = self.model.constraint_kind(j).value_count(self.model.dim());
            (0..n).filter_map(move |v| self.model.constraint_value_param(j, v))
        };
        let seen = |j: usize| !unseen.get(j).copied().unwrap_or(false);
        for j in (0..self.model.constraint_count()).filter(|&j| seen(j)) {
            for s in values(j) {
                if let Some(u) = used.get_mut(s) {
                    *u = true;
                }
            }
        }
        let mut held = vec![false; np];
        for j in (0..self.model.constraint_count()).filter(|&j| !seen(j)) {
            for s in values(j) {
                if s < np && !used[s] {
                    held[s] = true;
                }
            }
        }
        let relations = self
            .relations()
            .iter()
            .filter(|r| r.between.iter().all(|&j| seen(j)))
            .copied()
            .collect();
        DataStart {
            held,
            relations: Some(relations),
            gauge: self.gauge_without(unseen, false),
            ..self.clone()
        }
    }

    /// The same model for the fit of a calibration whose data have no pose on the
    /// constraints marked `unseen`: every relation kept (one to a known point, or to a
    /// value other relations fix, still says something), and held what the gauge rule
    /// holds of the equations of the constraints with poses and the relations (the unseen
    /// constraints' free values among them).
    #[must_use]
    pub fn without_poses_on(&self, unseen: &[bool]) -> DataStart<'a> {
        // Relations this model already left out (a fold's, [`DataStart::without_constraints`])
        // stay out of the analysis too: it must describe the fit that runs.
        DataStart {
            gauge: self.gauge_without(unseen, self.relations.is_none()),
            ..self.clone()
        }
    }

    /// [`CalibModel::identifiability_without`] when some constraint is `unseen`, else this
    /// model's own.
    fn gauge_without(
        &self,
        unseen: &[bool],
        relations: bool,
    ) -> Option<std::sync::Arc<crate::model::DataGauge>> {
        let np = self.model.param_count();
        if !unseen.contains(&true) {
            return self.gauge.clone();
        }
        let Some(mut g) = self
            .model
            .identifiability_without(unseen, relations)
            .filter(|g| g.held.len() == np && g.identifiable.len() == np)
        else {
            return self.gauge.clone();
        };
        // The unseen constraints' own values keep the whole spec's gauge: held where it holds
        // them, else left to the fit, whose rank check names what the data leave
        // undetermined (a socket without poses that one distance relation half fixes) rather
        // than pin a chart of it that the fit may run off.
        for j in (0..self.model.constraint_count()).filter(|&j| unseen.get(j) == Some(&true)) {
            for v in 0..self.model.constraint_kind(j).value_count(self.model.dim()) {
                if let Some(s) = self.model.constraint_value_param(j, v).filter(|&s| s < np) {
                    g.held[s] = self.model.param_held(s);
                }
            }
        }
        Some(std::sync::Arc::new(g))
    }

    /// The same model with the orientation weight `w` ([`CalibModel::orientation_weight`]:
    /// metres per radian, `σ_position/σ_orientation`).
    #[must_use]
    pub fn with_orientation_weight(&self, w: f64) -> DataStart<'a> {
        DataStart {
            orientation: Some(w),
            ..self.clone()
        }
    }

    /// The same model with the prior `prior` ([`CalibModel::prior`]).
    #[must_use]
    pub fn with_prior(&self, prior: OwnedPrior) -> DataStart<'a> {
        DataStart {
            prior: Some(std::sync::Arc::new(prior)),
            ..self.clone()
        }
    }
}

/// The data of a [`PriorRows`], owned.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OwnedPrior {
    /// [`PriorRows::params`].
    pub params: Vec<usize>,
    /// [`PriorRows::nominal`].
    pub nominal: Vec<f64>,
    /// [`PriorRows::rows`].
    pub rows: Vec<f64>,
}

impl CalibModel for DataStart<'_> {
    fn name(&self) -> &str {
        self.model.name()
    }
    fn dim(&self) -> usize {
        self.model.dim()
    }
    fn joint_count(&self) -> usize {
        self.model.joint_count()
    }
    fn joint_is_prismatic(&self, i: usize) -> bool {
        self.model.joint_is_prismatic(i)
    }
    fn joint_limits(&self, i: usize) -> Option<[f64; 2]> {
        self.model.joint_limits(i)
    }
    fn param_count(&self) -> usize {
        self.model.param_count()
    }
    fn param_name(&self, j: usize) -> &str {
        self.model.param_name(j)
    }
    fn param_nominal(&self, j: usize) -> f64 {
        self.nominal[j]
    }
    fn param_is_angle(&self, j: usize) -> bool {
        self.model.param_is_angle(j)
    }
    fn param_identifiable(&self, j: usize) -> bool {
        match &self.gauge {
            Some(g) => g.identifiable[j],
            None => self.model.param_identifiable(j),
        }
    }
    fn param_held(&self, j: usize) -> bool {
        self.held.get(j).copied().unwrap_or(false)
            || match &self.gauge {
                Some(g) => g.held[j],
                None => self.model.param_held(j),
            }
    }
    fn identifiable_count(&self) -> usize {
        match &self.gauge {
            Some(g) => g.count,
            None => self.model.identifiable_count(),
        }
    }
    fn identifiability_without(
        &self,
        unseen: &[bool],
        relations: bool,
    ) -> Option<crate::model::DataGauge> {
        // Relations this model left out (a fold's) stay out of the analysis of a model
        // wrapping it: the analysis must describe the fit that runs.
        self.model
            .identifiability_without(unseen, relations && self.relations.is_none())
    }
    fn basis_size(&self) -> usize {
        self.model.basis_size()
    }
    fn basis_ready(&self) -> Result<(), &str> {
        self.model.basis_ready()
    }
    fn basis_ready_within(&self, max_terms: usize) -> Result<(), &str> {
        self.model.basis_ready_within(max_terms)
    }
    fn basis_exceeds(&self, t: usize) -> Option<bool> {
        self.model.basis_exceeds(t)
    }
    fn basis_exceeds_pending(&self, t: usize) -> bool {
        self.model.basis_exceeds_pending(t)
    }
    fn basis_size_for_report(&self) -> Option<usize> {
        self.model.basis_size_for_report()
    }
    fn basis_name(&self, k: usize) -> &str {
        self.model.basis_name(k)
    }
    fn constant_index(&self) -> Option<usize> {
        self.model.constant_index()
    }
    fn constraint_count(&self) -> usize {
        self.model.constraint_count()
    }
    fn constraint_kind(&self, j: usize) -> ConstraintKind {
        self.model.constraint_kind(j)
    }
    fn constraint_values(&self, j: usize, p: &[f64], out: &mut [f64]) {
        self.model.constraint_values(j, p, out);
    }
    fn equation_count(&self) -> usize {
        self.model.equation_count()
    }
    fn equation_constraint(&self, e: usize) -> usize {
        self.model.equation_constraint(e)
    }
    fn basis(&self, q: &[f64], out: &mut [f64]) {
        self.model.basis(q, out);
    }
    fn generalized_params(&self, p: &[f64], out: &mut [f64]) {
        self.model.generalized_params(p, out);
    }
    fn jacobian(&self, p: &[f64], out: &mut [f64]) {
        self.model.jacobian(p, out);
    }
    fn jacobian_work(&self) -> Option<usize> {
        self.model.jacobian_work()
    }
    fn tip(&self, q: &[f64], p: &[f64], out: &mut [f64]) {
        self.model.tip(q, p, out);
    }
    fn tip_jacobian(&self, q: &[f64], p: &[f64], tip: &mut [f64], jac: &mut [f64]) {
        self.model.tip_jacobian(q, p, tip, jac);
    }
    fn constraint_value_param(&self, j: usize, v: usize) -> Option<usize> {
        self.model.constraint_value_param(j, v)
    }
    fn chain(&self) -> &[Factor] {
        self.model.chain()
    }
    fn relations(&self) -> &[Relation] {
        self.relations
            .as_deref()
            .unwrap_or_else(|| self.model.relations())
    }
    fn prior(&self) -> Option<PriorRows<'_>> {
        match &self.prior {
            Some(p) => Some(PriorRows {
                params: &p.params,
                nominal: &p.nominal,
                rows: &p.rows,
            }),
            None => self.model.prior(),
        }
    }
    fn orientation_weight(&self) -> f64 {
        self.orientation
            .unwrap_or_else(|| self.model.orientation_weight())
    }
}
