//! The calibration's weak-direction prior in a plan ([`crate::calibrate::prior`]).
//!
//! A plan is for the fit `calibrate` will run. That fit applies its prior when the data leave
//! an arm parameter weak (its standard deviation from the data alone above its prior one),
//! and then estimates with the information `JᵀJ/σ² + Σ⁻¹`. So the plan does the same: it
//! chooses with the data's information alone, and if that choice still leaves a parameter
//! weak (the fit will apply the prior), it chooses again with `Σ⁻¹` added to every design's
//! information (Bayesian D-optimality, `log det(G + Σ⁻¹ + Σ_{i∈S} JᵢᵀJᵢ)`), so that poses go
//! where the prior does not already know. Counting the prior where the fit will not apply
//! it would discount directions the fit then estimates from the data alone.

use nalgebra::DMatrix;

use crate::calibrate::prior::{self, PriorChoice};
use crate::model::CalibModel;
use crate::spec::Spec;

use super::{predicted_std, SelectError};

/// The prior over a design's free parameters, in its scaled columns (`θ'_k = s_k·θ_k`).
pub(super) struct PlanPrior {
    /// `Σ⁻¹` over the free parameters, `Σ⁻¹_ij/(s_i·s_j)`; zero off the arm (the base, the
    /// tool, the constraints' values have no prior).
    pub(super) information: DMatrix<f64>,
    /// Per free parameter its prior standard deviation `s_k·√Σ_kk`; `None` off the arm.
    std: Vec<Option<f64>>,
}

impl PlanPrior {
    /// The prior of `choice` over `free` (model indices) with column scales `scale`; `None`
    /// when there is none (off, or no free arm parameter).
    pub(super) fn of(
        model: &dyn CalibModel,
        spec: &Spec,
        free: &[usize],
        scale: &[f64],
        choice: PriorChoice,
    ) -> Option<PlanPrior> {
        let p = prior::information(model, Some(spec), choice)?;
        let n = free.len();
        let at: Vec<Option<usize>> = p
            .arm
            .iter()
            .map(|j| free.iter().position(|f| f == j))
            .collect();
        let mut information = DMatrix::zeros(n, n);
        let mut std = vec![None; n];
        for (a, ka) in at.iter().enumerate() {
            let Some(ka) = *ka else { continue };
            std[ka] = Some(p.std[a] * scale[ka]);
            for (b, kb) in at.iter().enumerate() {
                if let Some(kb) = *kb {
                    information[(ka, kb)] = p.information[(a, b)] / (scale[ka] * scale[kb]);
                }
            }
        }
        std.iter()
            .any(Option::is_some)
            .then_some(PlanPrior { information, std })
    }

    /// The free parameters (positions) that the data's information `info` (scaled columns)
    /// leaves weak, as the fit judges them: standard deviation above the prior's, or none.
    pub(super) fn weak(&self, info: &DMatrix<f64>) -> Result<Vec<usize>, SelectError> {
        let data = predicted_std(info)?;
        Ok(self
            .std
            .iter()
            .zip(&data)
            .enumerate()
            .filter_map(|(k, (t, s))| {
                let t = (*t)?;
                (s.is_nan() || *s > t).then_some(k)
            })
            .collect())
    }
}
