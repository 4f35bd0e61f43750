//! The joint axes of a URDF chain as Denavit-Hartenberg rows (see [`super::import`]'s module
//! docs): the common normal of consecutive axes where it is well placed, Hayati's row where
//! they are parallel or nearly so.
//!
//! **Hayati's row.** For axes `i`, `i + 1` within [`NEAR_PARALLEL`] of parallel, the row of
//! the pair drops the offset along axis `i` (`d_i = 0`; a prismatic joint keeps its reading's
//! `offset`, nominal 0, and writes its `theta` as a value, see [`super::import`]) and takes a
//! tilt `β` about the y axis right after the twist `α` (`Rz(θ)·Tz(0)·Tx(a)·Rx(α)·Ry(β)` in DH,
//! `Rx(α)·Ry(β)·Tx(a)·Rz(θ)·Tz(0)` in modified DH). With `(x_i, y_i = z × x_i, z)` the frame
//! after `Rz(θ)` and `w` the unit direction of axis `i + 1`, `Rx(α)·Ry(β)` takes `z` to
//! `w = sin β·x_i − sin α·cos β·y_i + cos α·cos β·z`, so `β = asin(w·x_i)` and `α` is the
//! angle turning `z` into `w`'s part ⊥ `x_i` about `x_i`; the next frame's x axis is
//! `cos β·x_i + sin α·sin β·y_i − cos α·sin β·z`.
//! - DH: the next origin `o + a·x_i` lies in the plane through the origin `o` ⊥ `z`, on axis
//!   `i + 1`: the point where that axis crosses the plane (`x_i` the previous x axis when it
//!   crosses at `o`).
//! - MDH: `Tx(a)` runs along the next frame's x axis `x'` (⊥ `w`), so the next origin is the
//!   foot `h` of `o` on axis `i + 1`, `x' = (h − o)/|h − o|`, and `x_i = ±(w × x')×z/|…|`,
//!   the sign of `w·z` (so that `x_i·x' = cos β > 0`; the previous x axis when `h = o`).
//!
//! At exactly parallel axes this is the normal through `o` with `β = 0`. The four entries
//! `θ, a, α, β` place any line that crosses the plane ⊥ `z` (every line within 90° of
//! parallel), smoothly in the line, where the common normal (`d`, `a`, `θ`) runs off to
//! infinity as the axes become parallel; the dropped offset along the pair is the next row's
//! (a shift of the whole rest of the chain along the nearly common direction).

use super::frame::{axpy, cross, dot, norm, unit, Iso};
use super::normal::{angle_about, common_normal, sub, Normal, PARALLEL};
use crate::error::{Error, Result};

/// Consecutive axes whose directions' cross product is at most this long (the sine of the
/// angle between them, about 5.7°) get Hayati's row (module docs). Beyond it the common
/// normal of axes `r` apart lies within about `10·r` of them.
pub const NEAR_PARALLEL: f64 = 0.1;

/// Points closer than this (metres) are one.
const SAME_POINT: f64 = 1e-13;

/// A moving joint's axis at zero readings, in the base link's frame.
pub(super) struct Line {
    pub(super) name: String,
    /// A point on the axis (the joint frame's origin).
    pub(super) p: [f64; 3],
    /// The unit direction (`+axis`).
    pub(super) u: [f64; 3],
    pub(super) prismatic: bool,
    pub(super) limits: Option<[f64; 2]>,
}

/// One row's values: `a`, `alpha`, `d`, `theta0` and Hayati's `beta` (0 unless the row holds
/// a tilt).
#[derive(Clone, Copy, Default)]
pub(super) struct RowValues {
    pub(super) a: f64,
    pub(super) alpha: f64,
    pub(super) d: f64,
    pub(super) theta: f64,
    pub(super) beta: f64,
}

/// The rows of a table, and per consecutive pair of axes whether it has Hayati's row.
pub(super) struct Rows {
    pub(super) vals: Vec<RowValues>,
    pub(super) hayati: Vec<bool>,
}

/// How axis `i + 1` is reached from a frame on axis `i`.
struct Step {
    /// Offset along axis `i` to the row's foot.
    d: f64,
    /// The row's x axis after `Rz(θ)` (⊥ axis `i`).
    x: [f64; 3],
    a: f64,
    alpha: f64,
    beta: f64,
    /// The next frame's x axis (⊥ axis `i + 1`).
    next_x: [f64; 3],
    /// Whether this is Hayati's row.
    hayati: bool,
}

/// The joint axes, and where to point errors about them.
pub(super) struct Axes<'a> {
    pub(super) lines: &'a [Line],
    pub(super) file: &'a str,
    pub(super) line_of: &'a dyn Fn(&str) -> Option<usize>,
}

impl Axes<'_> {
    /// Whether axes `i` and `i + 1` get Hayati's row.
    fn near_parallel(&self, i: usize) -> bool {
        norm(cross(self.lines[i].u, self.lines[i + 1].u)) <= NEAR_PARALLEL
    }

    /// The step from origin `o` on axis `i` (`x` the previous x axis, ⊥ axis `i`) to axis
    /// `i + 1`: the common normal, or Hayati's row (module docs; `mdh` picks the placement of
    /// `Tx(a)`), with a note for the latter.
    fn step(
        &self,
        i: usize,
        o: [f64; 3],
        x: [f64; 3],
        mdh: bool,
        notes: &mut Vec<String>,
    ) -> Result<Step> {
        let (z, next) = (self.lines[i].u, &self.lines[i + 1]);
        let w = next.u;
        if !self.near_parallel(i) {
            let nm: Normal = common_normal(o, z, next.p, w, x).map_err(|d| self.far(i, d))?;
            let alpha = angle_about(z, w, nm.x);
            let d = dot(sub(nm.f, o), z);
            return Ok(Step {
                d,
                x: nm.x,
                a: nm.a,
                alpha,
                beta: 0.0,
                next_x: nm.x,
                hayati: false,
            });
        }
        let parallel = norm(cross(z, w)) <= PARALLEL;
        // The next origin: where axis `i + 1` crosses the plane ⊥ z (DH), or the foot of `o`
        // on it (MDH); `w·z` is at least cos 5.7° here.
        let target = if mdh || parallel {
            axpy(next.p, dot(sub(o, next.p), w), w)
        } else {
            axpy(next.p, dot(sub(o, next.p), z) / dot(w, z), w)
        };
        let v = sub(target, o);
        let a = norm(v);
        let xi = if a <= SAME_POINT {
            x
        } else if mdh && !parallel {
            // ⊥ z and ⊥ the next frame's y axis `w × x'`, on the side of `x'` (`w·z` < 0 when
            // the axes are nearly opposite).
            let xi = unit(cross(cross(w, unit(v)), z));
            let s = dot(w, z).signum();
            [s * xi[0], s * xi[1], s * xi[2]]
        } else {
            unit(v)
        };
        let alpha = angle_about(z, w, xi);
        let beta = if parallel {
            0.0
        } else {
            dot(w, xi).clamp(-1.0, 1.0).asin()
        };
        let yi = cross(z, xi);
        let (sa, ca, sb, cb) = (alpha.sin(), alpha.cos(), beta.sin(), beta.cos());
        let next_x = if parallel {
            xi
        } else {
            unit(axpy(
                axpy([cb * xi[0], cb * xi[1], cb * xi[2]], sa * sb, yi),
                -ca * sb,
                z,
            ))
        };
        notes.push(self.hayati_note(i, beta));
        Ok(Step {
            d: 0.0,
            x: xi,
            a,
            alpha,
            beta,
            next_x,
            hayati: true,
        })
    }

    /// The note on the pair `i`, `i + 1` that gets Hayati's row with tilt `beta`.
    fn hayati_note(&self, i: usize, beta: f64) -> String {
        let (l, m) = (&self.lines[i], &self.lines[i + 1]);
        let left_out = if l.prismatic {
            format!(
                "; `{}`'s `theta` is written as its value (with the tilt, a fourth angle for \
                 the three turns of `alpha`, `beta` and `{}`'s own angle)",
                l.name, m.name
            )
        } else {
            format!(
                ", and `{}`'s offset `d` along the pair (0, redundant with the next one) is \
                 left out",
                l.name
            )
        };
        let (how, nominal) = if beta == 0.0 && norm(cross(l.u, m.u)) <= PARALLEL {
            ("have parallel axes".to_string(), "0".to_string())
        } else {
            let delta = norm(cross(l.u, m.u)).min(1.0).asin();
            (
                format!(
                    "have axes {delta:.3e} rad from parallel (the sine within the import's \
                     {NEAR_PARALLEL}, where their common normal would run off and turn with \
                     the smallest tilt)"
                ),
                format!("their own tilt, {beta:.3e} rad"),
            )
        };
        format!(
            "joints `{}` and `{}` {how}: the row of the pair is Hayati's, its normal taken \
             through the previous origin and the tilt of `{}`'s axis about the perpendicular \
             to that normal, which no DH table takes, its `beta` (nominal {nominal}){left_out}",
            l.name, m.name, m.name
        )
    }

    /// The input error for axes `i`, `i + 1` whose common normal lies `dist` metres away.
    fn far(&self, i: usize, dist: f64) -> Error {
        let lines = self.lines;
        Error::input(
            super::chain::at(
                self.file,
                (self.line_of)(&lines[i + 1].name),
                format!("joint `{}`.axis", lines[i + 1].name),
            ),
            format!(
                "the common normal of the axes of joints `{}` and `{}` lies {dist:.3e} m \
                 away (the import takes at most 1 km): the axes are more than \
                 {NEAR_PARALLEL} (sine) from parallel, so Hayati's row does not apply, and no \
                 bounded Denavit-Hartenberg table holds them; are the joint origins in metres?",
                lines[i].name,
                lines[i + 1].name
            ),
        )
    }

    /// Standard DH rows from frame 0 (`o0`, `x0`), and the last frame.
    pub(super) fn dh_values(
        &self,
        o0: [f64; 3],
        x0: [f64; 3],
        notes: &mut Vec<String>,
    ) -> Result<(Rows, Iso)> {
        let (lines, n) = (self.lines, self.lines.len());
        let mut rows = Rows {
            vals: vec![RowValues::default(); n],
            hayati: vec![false; n.saturating_sub(1)],
        };
        let (mut o, mut x) = (o0, x0);
        for (i, line) in lines.iter().enumerate().take(n.saturating_sub(1)) {
            let z = line.u;
            let s = self.step(i, o, x, false, notes)?;
            rows.vals[i] = RowValues {
                a: s.a,
                alpha: s.alpha,
                d: s.d,
                theta: angle_about(x, s.x, z),
                beta: s.beta,
            };
            rows.hayati[i] = s.hayati;
            o = axpy(axpy(o, s.d, z), s.a, s.x);
            x = s.next_x;
        }
        let z = lines[n - 1].u;
        Ok((rows, Iso::from_axes(x, cross(z, x), z, o)))
    }

    /// Modified DH rows from frame 0 (`o0`, `x0`), and the last frame.
    pub(super) fn mdh_values(
        &self,
        o0: [f64; 3],
        x0: [f64; 3],
        notes: &mut Vec<String>,
    ) -> Result<(Rows, Iso)> {
        let (lines, n) = (self.lines, self.lines.len());
        let mut rows = Rows {
            vals: vec![RowValues::default(); n],
            hayati: vec![false; n.saturating_sub(1)],
        };
        // `g`: where frame `i`'s row starts on axis `i` (the previous normal's foot).
        let (mut g, mut x) = (o0, x0);
        for (i, line) in lines.iter().enumerate().take(n.saturating_sub(1)) {
            let z = line.u;
            let s = self.step(i, g, x, true, notes)?;
            rows.vals[i].d = s.d;
            rows.vals[i].theta = angle_about(x, s.x, z);
            rows.vals[i + 1].a = s.a;
            rows.vals[i + 1].alpha = s.alpha;
            rows.vals[i + 1].beta = s.beta;
            rows.hayati[i] = s.hayati;
            let f = axpy(g, s.d, z);
            g = axpy(f, s.a, s.next_x);
            x = s.next_x;
        }
        let z = lines[n - 1].u;
        Ok((rows, Iso::from_axes(x, cross(z, x), z, g)))
    }
}
