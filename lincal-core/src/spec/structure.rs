//! A spec's structure as a short fingerprint: what a calibration result belongs to.
//!
//! A result file (`calibrate --format json`) lists the estimated parameters by name, and the
//! same names can mean another robot: the spec switched to another convention, a twist
//! written another way, a known length changed, a constraint of another kind. Its values
//! are then read into the wrong model and `predict`, `evaluate` and `compensate` answer
//! wrongly with exit 0. The fingerprint covers everything that gives the names their
//! meaning: the dimension and convention, every slot of the joints, origins, tool and base
//! (a parameter's name or an exact number), the constraints' kinds and slots, the relations,
//! which parameters are estimated, and the value of every known one. It leaves out what a
//! user edits without changing the model: the estimated parameters' nominals, their
//! tolerances, limits, names and descriptions.
//!
//! The text is hashed by FNV-1a (64 bits, written as 16 hexadecimal digits): not a
//! cryptographic digest, a check against mistakes.

use super::{Slot, Spec};

/// The fingerprint of `spec`'s structure (see the [module docs](self)).
///
/// # Example
/// ```
/// let text = "name: two\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n\
///             params:\n  a1: {nominal: 0.375}\n  th1: {nominal: 0}\n\
///             constraint: {point: {p: [1, 0]}}\n";
/// let a = lincal_core::spec::from_yaml_str(text, None).unwrap();
/// let b = lincal_core::spec::from_yaml_str(&text.replace("0.375", "0.4"), None).unwrap();
/// let c = lincal_core::spec::from_yaml_str(&text.replace("[1, 0]", "[1, 0.5]"), None).unwrap();
/// use lincal_core::spec::structure::fingerprint;
/// assert_eq!(fingerprint(&a), fingerprint(&b)); // an estimated nominal is not structure
/// assert_ne!(fingerprint(&a), fingerprint(&c)); // a known point is
/// ```
#[must_use]
pub fn fingerprint(spec: &Spec) -> String {
    let mut t = format!("dim {} convention {}\n", spec.dim, spec.convention.name());
    let slot = |t: &mut String, s: &Slot| {
        match s {
            Slot::Param(name) => t.push_str(name),
            Slot::Const(x) => t.push_str(&format!("={x}")),
        }
        t.push(' ');
    };
    for j in &spec.joints {
        t.push_str(&format!("joint {:?}: ", j.kind));
        for s in [&j.a, &j.alpha, &j.beta, &j.d, &j.home, &j.theta, &j.offset] {
            slot(&mut t, s);
        }
        for (_, s) in j.origin.slots() {
            slot(&mut t, s);
        }
        t.push('\n');
    }
    t.push_str("tool: ");
    spec.tool.iter().for_each(|s| slot(&mut t, s));
    spec.tool_rotation
        .iter()
        .flatten()
        .for_each(|s| slot(&mut t, s));
    t.push_str("\nbase: ");
    if let Some(b) = &spec.base {
        b.slots().iter().for_each(|(_, s)| slot(&mut t, s));
    }
    for c in &spec.constraints {
        t.push_str(&format!("\n{}: ", c.kind_name()));
        c.slots().into_iter().for_each(|s| slot(&mut t, s));
    }
    for r in &spec.relations {
        t.push_str(&format!(
            "\n{} {:?} {:e}",
            r.kind.name(),
            r.between,
            r.value
        ));
    }
    for p in &spec.params {
        if p.known {
            t.push_str(&format!("\nknown {} = {}", p.name, p.nominal));
        } else {
            t.push_str(&format!("\nestimated {}", p.name));
        }
    }
    // FNV-1a, 64 bits.
    let hash = t.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    format!("{hash:016x}")
}
