//! The units of joint readings as they are read: [`Angles`] (radians, degrees converted as
//! read, or radians with readings that look like degrees refused) and the per-reading
//! conversion and check of the reader.

use std::f64::consts::{PI, TAU};

/// How the revolute joints' readings of a data file are given (`--angles rad|deg|auto`).
/// Prismatic readings (metres) and measured tips are never converted nor checked.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Angles {
    /// Radians, taken as they are (readings beyond a full turn are only warned about).
    #[default]
    Rad,
    /// Degrees, converted to radians (×π/180) as they are read.
    Deg,
    /// Radians, but a reading beyond a full turn (|q| > 2π) that is also outside the
    /// joint's limits (or of a joint without limits) is refused as likely degrees, naming
    /// its file, line and column.
    Auto,
}

impl Angles {
    /// The name of the command line (`rad`, `deg`, `auto`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Angles::Rad => "rad",
            Angles::Deg => "deg",
            Angles::Auto => "auto",
        }
    }
}

impl std::str::FromStr for Angles {
    type Err = String;

    /// `rad`, `deg` or `auto` (what `--angles` and Python's `angles=` take).
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        match s {
            "rad" => Ok(Angles::Rad),
            "deg" => Ok(Angles::Deg),
            "auto" => Ok(Angles::Auto),
            _ => Err(format!(
                "`{}` is not a unit of joint angles: expected rad, deg or auto",
                crate::error::excerpt(s)
            )),
        }
    }
}

/// A full turn and the rounding allowed beyond it (and beyond the limits) before a reading
/// looks like degrees.
const TURN_TOLERANCE: f64 = 1e-9;

/// Revolute joint `i`'s reading `v` as stored, read with `angles`: converted to radians
/// (`Deg`), refused with the reason when it looks like degrees (`Auto`; `limits` are the
/// joint's), else as it is.
pub(super) fn revolute_reading(
    angles: Angles,
    i: usize,
    v: f64,
    limits: Option<[f64; 2]>,
) -> std::result::Result<f64, String> {
    match angles {
        Angles::Rad => Ok(v),
        Angles::Deg => Ok(v * (PI / 180.0)),
        Angles::Auto if looks_like_degrees(v, limits) => Err(degrees_message(i, v, limits)),
        Angles::Auto => Ok(v),
    }
}

/// Limits vouch for a reading beyond a full turn only up to this many radians either way (two
/// turns): no revolute joint of an arm turns ±170 rad, but `limits: [-170, 170]` is what a spec
/// written in degrees says, and its degree readings would all lie within it; a multi-turn
/// joint (`[-15, 15]`, a wrist of ±720°) keeps its readings up to two turns.
const VOUCHING_LIMIT: f64 = 2.0 * TAU;

/// The joint's `limits` within which a reading beyond a full turn is taken as radians: the
/// limits clamped to ±[`VOUCHING_LIMIT`].
fn vouching(limits: Option<[f64; 2]>) -> Option<[f64; 2]> {
    let v = VOUCHING_LIMIT + TURN_TOLERANCE;
    limits.map(|[lo, hi]| [lo.max(-v), hi.min(v)])
}

/// Whether the joint's `limits` reach beyond what they can vouch for ([`VOUCHING_LIMIT`]).
fn clamped(limits: Option<[f64; 2]>) -> bool {
    limits.is_some_and(|[lo, hi]| lo.abs().max(hi.abs()) > VOUCHING_LIMIT + TURN_TOLERANCE)
}

/// Whether a revolute reading `v` (taken as radians) looks like degrees: beyond a full turn,
/// and outside the joint's `limits` (as far as they can vouch for it: two turns, 4π) when
/// it has them.
#[must_use]
pub fn looks_like_degrees(v: f64, limits: Option<[f64; 2]>) -> bool {
    let beyond_turn = v.abs() > TAU + TURN_TOLERANCE;
    let outside =
        vouching(limits).is_none_or(|[lo, hi]| v < lo - TURN_TOLERANCE || v > hi + TURN_TOLERANCE);
    beyond_turn && outside
}

/// The refusal of `Angles::Auto` for joint `i`'s reading `v`.
fn degrees_message(i: usize, v: f64, limits: Option<[f64; 2]>) -> String {
    let limits = match limits {
        Some([lo, hi]) if clamped(limits) => format!(
            " and beyond two turns (the joint's limits [{lo}, {hi}] reach further, which a \
             spec in degrees would say too: limits are radians)"
        ),
        Some([lo, hi]) => format!(" and outside the joint's limits [{lo}, {hi}]"),
        None => String::new(),
    };
    format!(
        "joint q{} (revolute) reads {v}, beyond a full turn (2π){limits}: these look like \
         degrees: pass --angles deg to convert, or --angles rad to take them as radians \
         (Python: angles=\"deg\" or angles=\"rad\")",
        i + 1
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degrees_are_beyond_a_turn_and_outside_the_limits() {
        assert!(!looks_like_degrees(TAU, None));
        assert!(!looks_like_degrees(-TAU, None));
        assert!(looks_like_degrees(6.3, None));
        assert!(looks_like_degrees(-6.3, None));
        assert!(!looks_like_degrees(6.3, Some([-7.0, 7.0])));
        assert!(looks_like_degrees(7.5, Some([-7.0, 7.0])));
        assert!(looks_like_degrees(-90.0, Some([-7.0, 7.0])));
        assert!(!looks_like_degrees(3.0, Some([-1.0, 1.0])));
        // Limits vouch up to two turns: ±170 "rad" (degrees) does not pass 90, a multi-turn
        // joint keeps its radians.
        assert!(looks_like_degrees(90.0, Some([-170.0, 170.0])));
        assert!(degrees_message(0, 90.0, Some([-170.0, 170.0])).contains("limits are radians"));
        assert!(!looks_like_degrees(7.38, Some([-15.0, 15.0])));
        assert!(!looks_like_degrees(12.5, Some([-12.5664, 12.5664])));
        assert!(looks_like_degrees(13.0, Some([-15.0, 15.0])));
        for a in [Angles::Rad, Angles::Deg, Angles::Auto] {
            assert_eq!(a.name().parse::<Angles>(), Ok(a));
        }
        assert!("degrees".parse::<Angles>().is_err());
    }
}
