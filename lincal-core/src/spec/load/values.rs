//! Slots and numbers: a YAML value to a [`Slot`] (number, exact expression or parameter
//! name), to a bounded `f64` (no names), or a list of slots (any length, or exactly `N`);
//! each problem reported at its field.

use num_bigint::BigInt;
use num_rational::BigRational;

use super::loader::{describe, idx, Loader};
use crate::error::excerpt;
use crate::spec::node::Value;
use crate::spec::validate;
use crate::spec::{Exact, Slot};

/// The largest magnitude of any number in a spec (metres, radians, constraint coefficients):
/// far beyond any arm (a line 1 nm from the base origin has `|b| = 10⁹`), far below where
/// squares and products lose meaning in `f64`.
pub const MAX_MAGNITUDE: f64 = 1e9;

/// What a slot may be, for messages.
pub(super) const SLOT_HELP: &str = "a number, an expression like `pi/2`, or a parameter name";

impl Loader<'_> {
    /// A slot: number, exact expression or parameter name.
    pub(super) fn slot(&mut self, v: &Value, path: &str) -> Option<Slot> {
        match v {
            Value::Number(n) => {
                let exact = if let Some(i) = n.as_i64() {
                    Some(Exact::from_int(i))
                } else if let Some(u) = n.as_u64() {
                    Some(Exact::from_rational(BigRational::from_integer(
                        BigInt::from(u),
                    )))
                } else {
                    n.as_f64().and_then(Exact::from_f64)
                };
                match exact {
                    Some(e) => self.bounded(e.to_f64(), path).map(|_| Slot::Const(e)),
                    None => {
                        self.error(path, format!("expected a finite number, found `{n}`"));
                        None
                    }
                }
            }
            Value::String(s) => {
                let t = s.trim();
                if validate::is_identifier(t) && !t.eq_ignore_ascii_case("pi") {
                    return Some(Slot::Param(t.to_string()));
                }
                match Exact::parse(t) {
                    Ok(e) => self.bounded(e.to_f64(), path).map(|_| Slot::Const(e)),
                    Err(msg) => {
                        self.error(
                            path,
                            format!(
                                "expected {SLOT_HELP}, found `{}`, which does not parse: {msg}",
                                excerpt(s)
                            ),
                        );
                        self.orphan(v);
                        None
                    }
                }
            }
            other => {
                self.error(
                    path,
                    format!("expected {SLOT_HELP}, found {}", describe(other)),
                );
                self.orphan(other);
                None
            }
        }
    }

    /// A number or exact expression (no parameter names), as `f64`.
    pub(super) fn number(&mut self, v: &Value, path: &str, what: &str) -> Option<f64> {
        let x = self.number_unbounded(v, path, what)?;
        self.bounded(x, path)
    }

    /// `x` if it is finite and within [`MAX_MAGNITUDE`]; otherwise reported.
    fn bounded(&mut self, x: f64, path: &str) -> Option<f64> {
        if x.is_finite() && x.abs() <= MAX_MAGNITUDE {
            return Some(x);
        }
        if !x.is_finite() {
            self.error(path, format!("expected a finite number, found {x}"));
            return None;
        }
        self.error(
            path,
            format!(
                "the value {x:e} is out of range: numbers in a spec are metres or radians (or a \
                 constraint's coefficients), at most {MAX_MAGNITUDE:e} in magnitude"
            ),
        );
        None
    }

    /// A number or exact expression (no parameter names), as `f64`, not bounded.
    fn number_unbounded(&mut self, v: &Value, path: &str, what: &str) -> Option<f64> {
        match v {
            Value::Number(n) => n.as_f64().or_else(|| {
                self.error(path, format!("expected {what}, found `{n}`"));
                None
            }),
            Value::String(s) => {
                let t = s.trim();
                if validate::is_identifier(t) && !t.eq_ignore_ascii_case("pi") {
                    self.error(
                        path,
                        format!(
                            "expected {what}, found the name `{}` (names are not allowed here)",
                            excerpt(t)
                        ),
                    );
                    return None;
                }
                match Exact::parse(t) {
                    Ok(e) => Some(e.to_f64()),
                    Err(msg) => {
                        self.error(
                            path,
                            format!("expected {what}, found `{}`: {msg}", excerpt(s)),
                        );
                        None
                    }
                }
            }
            other => {
                self.error(path, format!("expected {what}, found {}", describe(other)));
                None
            }
        }
    }

    /// A list of slots (`None`, reported, when `v` is not a list).
    pub(super) fn slots(&mut self, v: &Value, path: &str, expected: &str) -> Option<Vec<Slot>> {
        let Value::Sequence(items) = v else {
            self.error(path, format!("expected {expected}, found {}", describe(v)));
            self.orphan(v);
            return None;
        };
        let mut out = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            out.push(self.slot(item, &idx(path, i)).unwrap_or_else(Slot::zero));
        }
        Some(out)
    }

    /// A list of exactly `N` slots.
    pub(super) fn array<const N: usize>(
        &mut self,
        v: &Value,
        path: &str,
        what: &str,
    ) -> Option<[Slot; N]> {
        let items = self.slots(v, path, &format!("a list of {N} entries ({what})"))?;
        let n = items.len();
        match <[Slot; N]>::try_from(items) {
            Ok(a) => Some(a),
            Err(items) => {
                self.error(path, format!("expected {N} entries ({what}), found {n}"));
                self.orphan_slots(&items);
                None
            }
        }
    }
}
