//! A spec's chain as numbers, frame by frame: what the URDF export needs beyond the tip.
//!
//! For joint `i` the **zero frame** `Z_i(q)` is the frame the joint's motion starts from,
//! so that the chain continues as `Z_i · Rz(q_i) · …` (revolute) or `Z_i · Tz(q_i) · …`
//! (prismatic):
//!
//! | convention, joint | `Z_i` | then |
//! |---|---|---|
//! | DH, revolute | `T·Rz(−home_i)` | `Rz(q_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i)` |
//! | DH, prismatic | `T·Rz(θ_i)·Tz(offset_i)` | `Tz(q_i)·Tx(a_i)·Rx(α_i)·Ry(β_i)` |
//! | MDH, revolute | `T·Rx(α_i)·Ry(β_i)·Tx(a_i)·Rz(−home_i)` | `Rz(q_i)·Tz(d_i)` |
//! | MDH, prismatic | `T·Rx(α_i)·Ry(β_i)·Tx(a_i)·Rz(θ_i)·Tz(offset_i)` | `Tz(q_i)` |
//!
//! (`β_i` Hayati's tilt, 0 unless the spec has one.) In `convention: urdf` a joint's origin
//! `O_i` comes first, `T·O_i·…`, and the row is modified DH with `a = α = β = 0`.
//!
//! with `T` the frame after joint `i − 1` (`T = B`, the base transform, before joint 1).
//! The z axis of `Z_i` is joint `i`'s axis and its origin lies on that axis, which is what
//! lets a URDF joint frame `U_i` (origin on the axis, rotation about `<axis>`) be written
//! as `Z_i·C_i⁻¹` with a constant `C_i`.

use super::chain::UrdfChain;
use super::frame::Iso;
use crate::error::{Error, Result};
use crate::spec::{Convention, JointKind, RowForm, Slot, Spec};

/// One joint's values.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Row {
    prismatic: bool,
    a: f64,
    alpha: f64,
    beta: f64,
    d: f64,
    home: f64,
    theta: f64,
    offset: f64,
    /// The joint's origin (`convention: urdf`; the identity otherwise).
    origin: Iso,
}

/// A spec's chain with every slot evaluated.
#[derive(Clone, Debug, PartialEq)]
pub struct NumChain {
    convention: Convention,
    rows: Vec<Row>,
    base: Iso,
    tool: [f64; 3],
    /// A tool frame's rotation `Rz(yaw)·Ry(pitch)·Rx(roll)` (`tool: {.., roll, pitch, yaw}`).
    tool_rotation: Option<Iso>,
}

fn rz(t: f64) -> Iso {
    Iso::rotation([0.0, 0.0, 1.0], t)
}
fn rx(t: f64) -> Iso {
    Iso::rotation([1.0, 0.0, 0.0], t)
}

fn ry(t: f64) -> Iso {
    Iso::rotation([0.0, 1.0, 0.0], t)
}
fn tz(d: f64) -> Iso {
    Iso::translation([0.0, 0.0, d])
}
fn tx(a: f64) -> Iso {
    Iso::translation([a, 0.0, 0.0])
}

impl NumChain {
    /// Evaluates the spec's slots; `value(name)` gives each parameter's value.
    ///
    /// # Errors
    /// An error naming the parameter when `value` has none for it, or the spec is planar
    /// (the export is for spatial chains).
    pub fn from_spec(spec: &Spec, value: &dyn Fn(&str) -> Option<f64>) -> Result<NumChain> {
        let v = |s: &Slot| -> Result<f64> {
            match s {
                Slot::Const(e) => Ok(e.to_f64()),
                Slot::Param(n) => value(n)
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| Error::other(format!("no value for parameter `{n}`"))),
            }
        };
        let mut rows = Vec::with_capacity(spec.joints.len());
        for j in &spec.joints {
            rows.push(Row {
                prismatic: j.kind == JointKind::Prismatic,
                a: v(&j.a)?,
                alpha: v(&j.alpha)?,
                beta: v(&j.beta)?,
                d: v(&j.d)?,
                home: v(&j.home)?,
                theta: v(&j.theta)?,
                offset: v(&j.offset)?,
                origin: Iso::from_xyz_rpy(
                    [v(&j.origin.x)?, v(&j.origin.y)?, v(&j.origin.z)?],
                    [v(&j.origin.roll)?, v(&j.origin.pitch)?, v(&j.origin.yaw)?],
                ),
            });
        }
        let base = match &spec.base {
            Some(b) => Iso::from_xyz_rpy(
                [v(&b.x)?, v(&b.y)?, v(&b.z)?],
                [v(&b.roll)?, v(&b.pitch)?, v(&b.yaw)?],
            ),
            None => Iso::IDENTITY,
        };
        let mut tool = [0.0; 3];
        for (t, s) in tool.iter_mut().zip(&spec.tool) {
            *t = v(s)?;
        }
        let tool_rotation = match &spec.tool_rotation {
            Some([r, p, y]) => Some(Iso::from_xyz_rpy([0.0; 3], [v(r)?, v(p)?, v(y)?])),
            None => None,
        };
        Ok(NumChain {
            convention: spec.convention,
            rows,
            base,
            tool,
            tool_rotation,
        })
    }

    /// The tool frame's rotation in the last frame, for a spec whose tool is a frame.
    #[must_use]
    pub fn tool_rotation(&self) -> Option<Iso> {
        self.tool_rotation
    }

    /// Number of joints.
    #[must_use]
    pub fn joint_count(&self) -> usize {
        self.rows.len()
    }

    /// Whether joint `i` is prismatic.
    #[must_use]
    pub fn is_prismatic(&self, i: usize) -> bool {
        self.rows.get(i).is_some_and(|r| r.prismatic)
    }

    /// The zero frames `Z_i(q)` of every joint and the tip `x(q)` (see the module docs).
    #[must_use]
    pub fn frames(&self, q: &[f64]) -> (Vec<Iso>, [f64; 3]) {
        let mut t = self.base;
        let mut z = Vec::with_capacity(self.rows.len());
        for (i, r) in self.rows.iter().enumerate() {
            let qi = q.get(i).copied().unwrap_or(0.0);
            // A joint's origin (the identity outside `convention: urdf`) comes first.
            t = t.mul(&r.origin);
            let (zi, rest) = match (self.convention.row(), r.prismatic) {
                (RowForm::Dh, false) => (
                    t.mul(&rz(-r.home)),
                    rz(qi)
                        .mul(&tz(r.d))
                        .mul(&tx(r.a))
                        .mul(&rx(r.alpha))
                        .mul(&ry(r.beta)),
                ),
                (RowForm::Dh, true) => (
                    t.mul(&rz(r.theta)).mul(&tz(r.offset + r.d)),
                    tz(qi).mul(&tx(r.a)).mul(&rx(r.alpha)).mul(&ry(r.beta)),
                ),
                (RowForm::Mdh, false) => (
                    t.mul(&rx(r.alpha))
                        .mul(&ry(r.beta))
                        .mul(&tx(r.a))
                        .mul(&rz(-r.home)),
                    rz(qi).mul(&tz(r.d)),
                ),
                (RowForm::Mdh, true) => (
                    t.mul(&rx(r.alpha))
                        .mul(&ry(r.beta))
                        .mul(&tx(r.a))
                        .mul(&rz(r.theta))
                        .mul(&tz(r.offset + r.d)),
                    tz(qi),
                ),
            };
            t = zi.mul(&rest);
            z.push(zi);
        }
        (z, t.apply(self.tool))
    }

    /// The tip `x(q)`.
    #[must_use]
    pub fn tip(&self, q: &[f64]) -> [f64; 3] {
        self.frames(q).1
    }
}

/// The largest distance between two tip functions over 20 joint vectors drawn in
/// `[−3, 3)ⁿ` by a fixed xorshift sequence from `seed`: the self-check of every URDF that is
/// written or read (exact agreement shows as rounding, about 1e-13 m).
pub(crate) fn worst_tip_gap(
    n: usize,
    seed: u64,
    a: impl Fn(&[f64]) -> [f64; 3],
    b: impl Fn(&[f64]) -> [f64; 3],
) -> f64 {
    let mut state = seed;
    let mut worst: f64 = 0.0;
    for _ in 0..20 {
        let q: Vec<f64> = (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0
            })
            .collect();
        let (x, y) = (a(&q), b(&q));
        worst = worst.max(super::frame::norm([x[0] - y[0], x[1] - y[1], x[2] - y[2]]));
    }
    worst
}
/// A measured pose's spec: its tool frame's axes against the URDF tip link's at fixed
/// pseudo-random readings (the position is [`check`]'s).
fn check_frames(spec: &crate::spec::Spec, chain: &UrdfChain, slack: f64) -> Result<()> {
    let frames = crate::spec::chain::Chain::from_spec(spec);
    let nominal: Vec<f64> = spec
        .estimated_params()
        .iter()
        .map(|p| p.nominal.to_f64())
        .collect();
    let n = spec.joints.len();
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut worst = 0.0f64;
    for _ in 0..20 {
        let q: Vec<f64> = (0..n)
            .map(|_| {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1);
                ((state >> 11) as f64 / (1u64 << 53) as f64) * 4.0 - 2.0
            })
            .collect();
        let (mut x, mut rot) = ([0.0; 3], [0.0; 9]);
        crate::model::chain::pose(&frames.factors, &q, &nominal, &mut x, &mut rot);
        let want = chain.tip_frame(&q);
        for c in 0..3 {
            for i in 0..3 {
                worst = worst.max((rot[3 * c + i] - want.r[i][c]).abs());
            }
        }
    }
    if worst > 1e-9 + slack {
        return Err(Error::other(format!(
            "the imported spec's tool frame differs from the URDF's tip link by {worst:.3e} (a bug)"
        )));
    }
    Ok(())
}

/// Loads the written spec and compares its tip with the URDF's at fixed pseudo-random
/// readings; the largest difference.
pub(super) fn check_import(
    yaml: &str,
    chain: &UrdfChain,
    tool: [f64; 3],
    slack: f64,
) -> Result<f64> {
    let spec = crate::spec::from_yaml_str(yaml, Some("(imported spec)"))
        .map_err(|e| Error::other(format!("the imported spec does not load (a bug): {e}")))?;
    let num = NumChain::from_spec(&spec, &|n| spec.param(n).map(|p| p.nominal.to_f64()))?;
    let worst = worst_tip_gap(
        num.joint_count(),
        0x9e37_79b9_7f4a_7c15,
        |q| num.tip(q),
        |q| chain.tip_frame(q).apply(tool),
    );
    if worst > 1e-9 + slack {
        return Err(Error::other(format!(
            "the imported spec's tip differs from the URDF's by {worst:.3e} m (a bug)"
        )));
    }
    if spec.is_measured_pose() {
        check_frames(&spec, chain, slack)?;
    }
    Ok(worst)
}
