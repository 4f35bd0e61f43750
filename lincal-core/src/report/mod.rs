//! Reports: what `lincal basis` and `lincal calibrate` print, as JSON and as readable text.
//!
//! The JSON contract of `shared/interface.md` is a pair of types, [`BasisReport`] and
//! [`CalibrateReport`] (serialized by `serde`, fields in the order written): every field the
//! interface lists is a field there, with that name and meaning; the extras are documented on
//! each field. A number that is not finite is `null` (JSON has no NaN).
//!
//! # Example
//! ```
//! let yaml = "
//! name: two_link
//! dim: 2
//! joints:
//!   - {type: revolute, a: a1, home: th1}
//!   - {type: revolute, a: a2, home: th2}
//! params:
//!   a1: {nominal: 0.375}
//!   a2: {nominal: 0.425}
//!   th1: {nominal: 0}
//!   th2: {nominal: 0}
//!   b1: {nominal: -1.8}
//!   b2: {nominal: -0.5}
//! constraint:
//!   line: {b: [b1, b2]}
//! ";
//! let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
//! let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
//! let json = lincal_core::report::basis_json(&model);
//! assert_eq!(json["basis_size"], 5);
//! assert_eq!(json["identifiable_count"], 4);
//! assert!(lincal_core::report::basis_text(&model).contains("identifiable combinations: 4"));
//! ```

#[cfg(feature = "html")]
pub mod html;
mod json;
mod text;
mod validation;

/// `v` as a person reads a stated value: plainly from 10⁻⁴ to 10⁶ (and 0), in exponent form
/// beyond (a relation of `1e-300` is not 300 zeros).
pub(crate) fn stated(v: f64) -> String {
    if v == 0.0 || (1e-4..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

pub use json::{
    basis_json, calibrate_json, BasisReport, CalibrateReport, ConstraintReport, GeneralizedParams,
    Named, ParamReport, PoseReport, RelationReport, RobustReport,
};
pub use text::{basis_text, calibrate_text, relation_string};
pub use validation::{cross_validation_text, evaluation_text};
