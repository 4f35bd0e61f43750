//! The one trait every calibration model implements, whether derived at compile time
//! (`#[derive(CalibModel)]`) or built at run time from a YAML spec
//! ([`crate::symbolic::SymbolicModel`]). The solver, extraction, refinement and simulation take
//! `&dyn CalibModel`: one solver, two sources of models.
//!
//! The trait is `no_std`, object safe and `Sync` (the fits split poses across threads); buffers are caller-provided slices, so evaluation
//! never allocates.
//!
//! # The mathematics
//! For equation `e` of the constraint(s), `h_e(q; p) = Σ_k c_{e,k}(p) · Φ̃_k(q)` where `Φ̃` is
//! the column-reduced basis (the paper's generalized robot variables, the constant function
//! included when present) and `c_e(p)` the generalized parameters. For a `measured` tip the
//! equations are the tip coordinates themselves, `x_e(q; p) = c_e(p)·Φ̃(q)`.

pub mod chain;
pub mod factored;
pub mod geometry;
pub mod rotation;

use geometry::ConstraintKind;

/// The identifiability of a model's equations restricted to some of its constraints
/// ([`CalibModel::identifiability_without`]), per estimated parameter.
#[cfg(feature = "std")]
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DataGauge {
    /// Held at its nominal by the gauge rule.
    pub held: Vec<bool>,
    /// Identifiable on its own.
    pub identifiable: Vec<bool>,
    /// Independent identifiable combinations.
    pub count: usize,
}

/// A Gaussian prior as residual rows: `rows·(p[params] − nominal)`, `rows` row-major with
/// `params.len()` columns ([`CalibModel::prior`]).
#[derive(Clone, Copy, Debug)]
pub struct PriorRows<'a> {
    /// The parameters `S` the prior involves (indices into `p`).
    pub params: &'a [usize],
    /// Their prior means `μ` (the nominals).
    pub nominal: &'a [f64],
    /// The rows `L`, row-major, `params.len()` columns.
    pub rows: &'a [f64],
}

/// A kinematic calibration model: basis `Φ̃(q)`, generalized parameters `c(p)`, their
/// Jacobian `∂c/∂p`, forward kinematics and the constraint geometry.
///
/// `p` is always the vector of *estimated* parameters (spec order, known ones left out).
pub trait CalibModel: Sync {
    /// The spec's name.
    fn name(&self) -> &str;
    /// 2 (planar) or 3.
    fn dim(&self) -> usize;
    /// Number of joints `n` (length of `q`).
    fn joint_count(&self) -> usize;
    /// Whether joint `i` is prismatic.
    fn joint_is_prismatic(&self, i: usize) -> bool;
    /// Limits of joint `i`'s reading, if the spec gives them.
    fn joint_limits(&self, i: usize) -> Option<[f64; 2]>;
    /// Number of estimated parameters (length of `p`).
    fn param_count(&self) -> usize;
    /// Name of estimated parameter `j`.
    fn param_name(&self, j: usize) -> &str;
    /// Nominal value of estimated parameter `j`.
    fn param_nominal(&self, j: usize) -> f64;
    /// Whether parameter `j` is an angle (enters through cos/sin).
    fn param_is_angle(&self, j: usize) -> bool;
    /// Whether parameter `j` is identifiable on its own.
    fn param_identifiable(&self, j: usize) -> bool;
    /// Whether the gauge rule holds parameter `j` at its nominal value.
    fn param_held(&self, j: usize) -> bool;
    /// Number of independent parameter combinations the constraint determines.
    fn identifiable_count(&self) -> usize;
    /// `K`, the size of the column-reduced basis (0 when [`CalibModel::basis_ready`] fails).
    fn basis_size(&self) -> usize;
    /// Whether the basis `Φ̃` and `c(p)` can be evaluated. A run-time model builds them on
    /// first use (this call may do it) and can find them beyond its term bound: `Err` with
    /// the reason then, and the basis, `c` and `∂c/∂p` write nothing. Generated models
    /// always have them.
    fn basis_ready(&self) -> Result<(), &str> {
        Ok(())
    }
    /// [`CalibModel::basis_ready`], building the basis (when it is not built yet) within
    /// `max_terms` terms of expansion at most, whatever larger bound the model has: a start
    /// that only may use the basis does not pay seconds and gigabytes for one it cannot
    /// afford to solve with. A basis refused here stays refused for this model.
    fn basis_ready_within(&self, max_terms: usize) -> Result<(), &str> {
        let _ = max_terms;
        self.basis_ready()
    }
    /// Whether `K > t`, when that is known without building the basis: `Some(true)` when
    /// proved, `Some(false)` when `K ≤ t` is known, `None` when only the basis would tell.
    fn basis_exceeds(&self, t: usize) -> Option<bool> {
        Some(self.basis_size() > t)
    }
    /// Whether [`CalibModel::basis_exceeds`]`(t)` would now have to prove `K > t` from
    /// samples, on the caller's thread, while `K` itself is being learnt on another (a
    /// run-time model building its basis ahead). A caller with other work to do (a fit that
    /// can start from the nominals) does it first and asks later, when `K` costs no proof.
    fn basis_exceeds_pending(&self, _t: usize) -> bool {
        false
    }
    /// `K` for a report, when it is known or costs little to learn (a run-time model builds
    /// a small basis for it, not a large one); `None` otherwise.
    fn basis_size_for_report(&self) -> Option<usize> {
        Some(self.basis_size())
    }
    /// Name of basis function `k` (e.g. `"c1*c2 - s1*s2"`).
    fn basis_name(&self, k: usize) -> &str;
    /// Index of the constant function `1` in the basis, when the basis holds it exactly.
    fn constant_index(&self) -> Option<usize>;
    /// Number of constraints (1 unless the spec has a list).
    fn constraint_count(&self) -> usize;
    /// Kind of constraint `j`.
    fn constraint_kind(&self, j: usize) -> ConstraintKind;
    /// The numeric values of constraint `j` (canonical order, see [`crate::model::geometry`]).
    fn constraint_values(&self, j: usize, p: &[f64], out: &mut [f64]);
    /// Total number of equations `E` over all constraints.
    fn equation_count(&self) -> usize;
    /// Which constraint equation `e` belongs to.
    fn equation_constraint(&self, e: usize) -> usize;
    /// `Φ̃(q)`: writes `K` values.
    fn basis(&self, q: &[f64], out: &mut [f64]);
    /// `c(p)`: writes `E·K` values, equation-major (`out[e*K + k] = c_{e,k}(p)`).
    fn generalized_params(&self, p: &[f64], out: &mut [f64]);
    /// `∂c/∂p`: writes `E·K·P` values, `out[(e*K + k)*P + j] = ∂c_{e,k}/∂p_j`.
    fn jacobian(&self, p: &[f64], out: &mut [f64]);
    /// About how many multiplications one [`CalibModel::jacobian`] takes, where the model
    /// knows (a run-time model: the factors of its compiled `c(p)`): the extraction's
    /// restarts budget their work by it. `None`: not known (counted as cheap).
    fn jacobian_work(&self) -> Option<usize> {
        None
    }
    /// Forward kinematics: the tip `x(q; p)`, `dim` values.
    fn tip(&self, q: &[f64], p: &[f64], out: &mut [f64]);
    /// The tip and its exact Jacobian `∂x/∂p`: `tip` gets `dim` values, `jac` the `dim × P`
    /// matrix row-major (`jac[i*P + j] = ∂x_i/∂p_j`); see [`crate::model::chain`].
    fn tip_jacobian(&self, q: &[f64], p: &[f64], tip: &mut [f64], jac: &mut [f64]);
    /// The estimated parameter that value `v` of constraint `j` is (canonical order of
    /// [`crate::model::geometry`]), or `None` for a fixed value; `∂values/∂p` is this selection.
    fn constraint_value_param(&self, j: usize, v: usize) -> Option<usize>;
    /// The kinematic chain as elementary motions ([`crate::model::chain`]): the structure behind
    /// [`CalibModel::tip`], used to find the chain's exact discrete symmetries.
    fn chain(&self) -> &[crate::model::chain::Factor];
    /// The relations between the constraints of the list (spec `relations:`), each an exact
    /// equation on the constraints' values (see [`crate::model::geometry::relation_residual_in`]).
    fn relations(&self) -> &[crate::model::geometry::Relation] {
        &[]
    }
    /// The identifiability when the constraints marked `unseen` have no poses
    /// ([`DataGauge`]), with the relations (`relations`: all of them; otherwise only those
    /// between constraints with poses): their equations gone, directions the whole spec pins
    /// may be free (two unknown sockets of a list whose third, a known point, fixed the
    /// arm's scale), and a fit of the other poses must hold them too, or it runs along them
    /// (the scale to zero, where every residual vanishes). `None` (the default): the model
    /// cannot analyse a part of itself (a derived model's analysis is fixed at build time),
    /// and its own stands.
    #[cfg(feature = "std")]
    fn identifiability_without(&self, unseen: &[bool], relations: bool) -> Option<DataGauge> {
        let _ = (unseen, relations);
        None
    }
    /// The Gaussian prior the parameter-space fit adds, as residual rows `L·(p_S − μ)`
    /// (metres) over the parameters `S` ([`PriorRows`]); `None` (the default) adds none. A
    /// calibration with a prior sets `LᵀL = σ̂²·Σ⁻¹`, `σ̂` the residual's noise level and `Σ`
    /// the prior covariance, so the fit minimises `Σ‖g‖²/σ̂² + (p_S − μ)ᵀΣ⁻¹(p_S − μ)` times
    /// `σ̂²`: the maximum a posteriori estimate.
    fn prior(&self) -> Option<PriorRows<'_>> {
        None
    }
    /// For a `measured_pose` constraint, the weight `w` (metres per radian) of the orientation
    /// residual against the position residual: the fit minimises
    /// `Σ ‖x − x_m‖² + w²·‖log(R_mᵀR)‖²`, so `w = σ_position/σ_orientation` weighs each by its
    /// noise. A spec that states both noise levels gives that ratio; otherwise the
    /// calibration estimates it from the data (variance components) and the default,
    /// [`geometry::DEFAULT_ORIENTATION_WEIGHT`], is only its start.
    fn orientation_weight(&self) -> f64 {
        geometry::DEFAULT_ORIENTATION_WEIGHT
    }
    /// The tool frame `T(q; p)` of a spatial chain: its origin `tip` (the tip) and its
    /// rotation `rot`, column-major (`rot[3c + i]` is component `i` of the frame's axis `c` in
    /// the world), through [`CalibModel::chain`] (NaN for a model without one).
    fn tool_pose(&self, q: &[f64], p: &[f64], tip: &mut [f64; 3], rot: &mut [f64; 9]) {
        let factors = self.chain();
        if factors.is_empty() {
            *tip = [f64::NAN; 3];
            *rot = [f64::NAN; 9];
            return;
        }
        let mut f = [chain::Motion::default(); 64];
        if factors.len() <= f.len() {
            chain::prepare(factors, p, &mut f[..factors.len()]);
            chain::pose_prepared(factors, &f[..factors.len()], q, tip, rot);
        } else {
            // Longer than any arm: the unprepared path, one factor at a time.
            chain::pose(factors, q, p, tip, rot);
        }
    }
}
