//! Planes written by normal and offset (`plane: {normal: [..], offset: d}`, `n·x = d`), as
//! the calibration reports them: unit-normalised.
//!
//! The fitted `(n, d)` of such a plane is one representative of the whole family
//! `(λn, λd)`, `λ ≠ 0` (for an unknown normal the scale is a gauge direction, fixed by holding
//! one entry; a known normal may have any nonzero length). The report gives the one with a
//! unit normal: `n̂ = n/‖n‖` and `d̂ = d/‖n‖`, the plane's signed distance from the base
//! origin along `n̂` (metres). The parameters themselves stay as fitted.

use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;

/// One plane by normal of the spec, at the calibrated parameters, unit-normalised.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PlaneFit {
    /// Index of the constraint (0 for a single `constraint:`).
    pub constraint: usize,
    /// The unit normal `n̂ = n/‖n‖`.
    pub normal: [f64; 3],
    /// `d̂ = d/‖n‖`: the signed distance of the plane from the base origin along `n̂`, metres.
    pub offset: f64,
    /// `‖n‖` of the fitted normal (the scale divided out; 1 for a unit normal).
    pub scale: f64,
}

/// Every plane by normal of `model` at `p`, unit-normalised (see the module docs); empty when
/// the model has none. A zero normal (which validation refuses) is skipped.
#[must_use]
pub fn plane_fits(model: &dyn CalibModel, p: &[f64]) -> Vec<PlaneFit> {
    let mut out = Vec::new();
    for j in 0..model.constraint_count() {
        if model.constraint_kind(j) != ConstraintKind::PlaneNormal {
            continue;
        }
        let mut v = [0.0; 4];
        model.constraint_values(j, p, &mut v);
        let scale = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if scale > 0.0 && scale.is_finite() {
            out.push(PlaneFit {
                constraint: j,
                normal: [v[0] / scale, v[1] / scale, v[2] / scale],
                offset: v[3] / scale,
                scale,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::SymbolicModel;

    #[test]
    fn normalises_the_fitted_plane() {
        let yaml = "name: t\ndim: 3\njoints:\n  - {type: revolute, a: 0.3, d: 0.2, home: h}\n\
                    constraint: {plane: {normal: [0, n2, 2], offset: d}}\nparams:\n  \
                    h: {nominal: 0}\n  n2: {nominal: 0, known: true}\n  d: {nominal: 0}\n";
        let spec = crate::spec::from_yaml_str(yaml, None).unwrap();
        let model = SymbolicModel::from_spec(&spec).unwrap();
        let fits = plane_fits(&model, &[0.0, 0.5]);
        assert_eq!(fits.len(), 1);
        assert_eq!(fits[0].normal, [0.0, 0.0, 1.0]);
        assert!((fits[0].offset - 0.25).abs() < 1e-15 && (fits[0].scale - 2.0).abs() < 1e-15);
    }
}
