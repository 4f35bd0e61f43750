//! The kinematic chain as a list of elementary motions, and its tip with the exact Jacobian
//! `∂x/∂p`, `no_std`.
//!
//! Every spec's forward kinematics is a product of elementary rotations and translations
//! about the coordinate axes of the current frame,
//!
//! `T = B · A_1 ⋯ A_n · Tx(t_x)·Ty(t_y)·Tz(t_z)`,  `B = Tx(x)Ty(y)Tz(z)·Rz(yaw)Ry(pitch)Rx(roll)`,
//!
//! with `A_i = Rz(θ_i)Tz(d_i)Tx(a_i)Rx(α_i)` (DH) or `Rx(α_i)Tx(a_i)Rz(θ_i)Tz(d_i)` (MDH), and
//! the tip `x = T·0` is the origin of the last frame. Each [`Factor`] is one such motion whose
//! amount is affine in the joint reading and the parameters (`θ_i = q_i − home_i`,
//! `d_i = q_i + offset_i + d_i`, a constant, or one parameter).
//!
//! # The Jacobian
//! A rotation about the world axis `w` through the point `o` (the frame's axis and origin just
//! before the factor) moves the tip with velocity `w × (x − o) = o × w + w × x`; a translation
//! along `w` moves it with velocity `w`. So each parameter `p_j` carries a twist
//! `(ω_j, v_j) = Σ coef·(w, o × w)` (rotations) `+ Σ coef·(0, w)` (translations), collected in
//! one forward pass, and `∂x/∂p_j = v_j + ω_j × x`. This is exact (no differences), and costs
//! `O(factors + P)` per pose, so the parameter-space fit ([`crate::fit::geometric`]) is `O(N·P²)` per
//! iteration, dominated by the normal equations, not by the kinematics.
//!
//! Run-time models ([`crate::symbolic::SymbolicModel`]) build the chain from the spec
//! (`spec::chain::Chain::from_spec`, with `std`); derived models embed it as a `static` table and call the same
//! [`tip_jacobian`], so both model sources agree by construction.

/// A coordinate axis of the current frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// x.
    X,
    /// y.
    Y,
    /// z.
    Z,
}

impl Axis {
    const fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// One estimated parameter's share of a factor's amount: `coef · p[param]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Term {
    /// Index into the estimated parameters `p`.
    pub param: usize,
    /// Its coefficient (`−1` for a home offset, `+1` otherwise).
    pub coef: f64,
}

/// One elementary motion of the chain: a rotation about, or a translation along, an axis of
/// the current frame, by `constant + q[joint] + Σ terms`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Factor {
    /// Rotation (`true`) or translation (`false`).
    pub rotation: bool,
    /// The axis.
    pub axis: Axis,
    /// The constant part of the amount (radians or metres).
    pub constant: f64,
    /// The joint whose reading adds to the amount, if any.
    pub joint: Option<usize>,
    /// Up to two parameter terms (a prismatic joint's `offset` and `d`).
    pub terms: [Option<Term>; 2],
}

impl Factor {
    /// The amount `constant + q[joint] + Σ coef·p[param]`.
    #[inline]
    #[must_use]
    pub fn amount(&self, q: &[f64], p: &[f64]) -> f64 {
        let mut v = self.constant;
        if let Some(i) = self.joint {
            v += q[i];
        }
        for t in self.terms.iter().flatten() {
            v += t.coef * p[t.param];
        }
        v
    }
}

/// A frame: rotation by columns (`r[c]` is axis `c` in world coordinates) and origin.
#[derive(Clone, Copy)]
struct Frame {
    r: [[f64; 3]; 3],
    o: [f64; 3],
}

impl Frame {
    const IDENTITY: Frame = Frame {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        o: [0.0; 3],
    };

    /// Right-multiplies by the factor's motion `m`.
    #[inline]
    fn apply(&mut self, f: &Factor, m: Motion) {
        let a = f.axis.index();
        if f.rotation {
            // R·Rot(axis, v): the two other columns rotate in their plane.
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            let (s, co) = (m.sin, m.cos);
            let (rb, rc) = (self.r[b], self.r[c]);
            for k in 0..3 {
                self.r[b][k] = co * rb[k] + s * rc[k];
                self.r[c][k] = co * rc[k] - s * rb[k];
            }
        } else {
            for k in 0..3 {
                self.o[k] += m.amount * self.r[a][k];
            }
        }
    }
}

/// A factor's motion by a given amount: the amount, and its sine and cosine for a rotation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    /// The amount (radians or metres); for a joint's factor in a [`prepare`]d table, the
    /// part without the joint reading.
    pub amount: f64,
    /// `sin amount` (rotations whose amount does not involve a joint).
    pub sin: f64,
    /// `cos amount` (the same).
    pub cos: f64,
}

impl Motion {
    /// The motion of `f` by `v`.
    #[inline]
    fn of(f: &Factor, v: f64) -> Motion {
        if f.rotation {
            let (sin, cos) = sin_cos(v);
            Motion {
                amount: v,
                sin,
                cos,
            }
        } else {
            Motion {
                amount: v,
                sin: 0.0,
                cos: 1.0,
            }
        }
    }
}

/// The pose-independent part of every factor at parameters `p`, into `out` (one entry per
/// factor): a factor without a joint gets its whole motion (so its sine and cosine are
/// computed once for all poses, not once per pose), a joint's factor the amount without the
/// reading. Used with [`tip_prepared`] and [`tip_jacobian_prepared`].
///
/// # Panics
/// If `out` is shorter than `chain` (a programming error).
pub fn prepare(chain: &[Factor], p: &[f64], out: &mut [Motion]) {
    for (m, f) in out.iter_mut().zip(chain) {
        let mut v = f.constant;
        for t in f.terms.iter().flatten() {
            v += t.coef * p[t.param];
        }
        // A joint's factor keeps the sine and cosine of its reading-free part too, for
        // readings whose own sine and cosine are known ([`Readings::trig`]).
        *m = Motion::of(f, v);
    }
}

/// One pose's joint readings `q` and, when precomputed, `[sin q_i, cos q_i]` per joint.
///
/// A revolute joint's factor turns by `a + q_i` (`a` the reading-free part of its amount,
/// [`prepare`]d once per parameter vector). With `trig` its sine and cosine come from the
/// angle-addition formulas `sin(a + q) = sin a·cos q + cos a·sin q`,
/// `cos(a + q) = cos a·cos q − sin a·sin q`: four products instead of a `sincos` per joint and
/// pose, since the readings do not change while a fit iterates.
#[derive(Clone, Copy, Debug)]
pub struct Readings<'a> {
    /// The joint readings.
    pub q: &'a [f64],
    /// `[sin q_i, cos q_i]` for each joint, or `None` (computed when needed).
    pub trig: Option<&'a [[f64; 2]]>,
}

impl<'a> From<&'a [f64]> for Readings<'a> {
    fn from(q: &'a [f64]) -> Self {
        Readings { q, trig: None }
    }
}

#[cfg(feature = "std")]
impl<'a> From<&'a Vec<f64>> for Readings<'a> {
    fn from(q: &'a Vec<f64>) -> Self {
        Readings { q, trig: None }
    }
}

/// `[sin q_i, cos q_i]` of every reading of `q`, appended to `out` (the table of
/// [`Readings::trig`]).
#[cfg(feature = "std")]
pub fn reading_trig(q: &[f64], out: &mut Vec<[f64; 2]>) {
    out.extend(q.iter().map(|&v| {
        let (s, c) = sin_cos(v);
        [s, c]
    }));
}

/// The motion of factor `f` for the pose `r`, from its prepared entry.
#[inline]
fn posed(f: &Factor, m: Motion, r: &Readings<'_>) -> Motion {
    match (f.joint, r.trig) {
        (Some(i), Some(t)) if f.rotation => {
            let [sq, cq] = t[i];
            Motion {
                amount: m.amount + r.q[i],
                sin: m.sin * cq + m.cos * sq,
                cos: m.cos * cq - m.sin * sq,
            }
        }
        (Some(i), _) => Motion::of(f, m.amount + r.q[i]),
        (None, _) => m,
    }
}

/// `(sin v, cos v)` in one call: the platform's `sincos` with std (about twice as fast as
/// two `libm` calls, which each reduce the argument again), `libm`'s without.
#[inline]
fn sin_cos(v: f64) -> (f64, f64) {
    #[cfg(feature = "std")]
    {
        v.sin_cos()
    }
    #[cfg(not(feature = "std"))]
    {
        libm::sincos(v)
    }
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The tip `x(q; p)`: writes `dim` values.
pub fn tip(chain: &[Factor], dim: usize, q: &[f64], p: &[f64], out: &mut [f64]) {
    let mut f = Frame::IDENTITY;
    for factor in chain {
        f.apply(factor, Motion::of(factor, factor.amount(q, p)));
    }
    out[..dim].copy_from_slice(&f.o[..dim]);
}

/// [`tip`] from a [`prepare`]d table (`motions`, one per factor) for the pose `q`.
pub fn tip_prepared<'r>(
    chain: &[Factor],
    motions: &[Motion],
    dim: usize,
    q: impl Into<Readings<'r>>,
    out: &mut [f64],
) {
    let r = q.into();
    let mut f = Frame::IDENTITY;
    for (factor, &m) in chain.iter().zip(motions) {
        f.apply(factor, posed(factor, m, &r));
    }
    out[..dim].copy_from_slice(&f.o[..dim]);
}

/// The tip and its exact Jacobian: `tip` gets `dim` values, `jac` (`dim × P`, row-major,
/// `jac[i*P + j] = ∂x_i/∂p_j`) is overwritten; `twists` is scratch of `P` entries (see the
/// module docs).
///
/// # Panics
/// If a buffer is shorter than stated (a programming error).
pub fn tip_jacobian(
    chain: &[Factor],
    dim: usize,
    q: &[f64],
    p: &[f64],
    tip: &mut [f64],
    jac: &mut [f64],
    twists: &mut [[f64; 6]],
) {
    walk_jacobian(
        chain,
        |factor, _| Motion::of(factor, factor.amount(q, p)),
        dim,
        tip,
        jac,
        twists,
    );
}

/// [`tip_jacobian`] from a [`prepare`]d table (`motions`, one per factor) for the pose `q`.
///
/// # Panics
/// If a buffer is shorter than stated (a programming error).
pub fn tip_jacobian_prepared<'r>(
    chain: &[Factor],
    motions: &[Motion],
    dim: usize,
    q: impl Into<Readings<'r>>,
    tip: &mut [f64],
    jac: &mut [f64],
    twists: &mut [[f64; 6]],
) {
    let r = q.into();
    walk_jacobian(
        chain,
        |factor, i| posed(factor, motions[i], &r),
        dim,
        tip,
        jac,
        twists,
    );
}

/// The forward pass of [`tip_jacobian`], each factor's motion from `motion(factor, index)`.
#[inline]
fn walk_jacobian(
    chain: &[Factor],
    motion: impl Fn(&Factor, usize) -> Motion,
    dim: usize,
    tip: &mut [f64],
    jac: &mut [f64],
    twists: &mut [[f64; 6]],
) {
    let f = walk_twists(chain, motion, twists);
    let np = twists.len();
    tip[..dim].copy_from_slice(&f.o[..dim]);
    for (j, tw) in twists.iter().enumerate() {
        let w = [tw[0], tw[1], tw[2]];
        let wx = cross(&w, &f.o);
        for i in 0..dim {
            jac[i * np + j] = tw[3 + i] + wx[i];
        }
    }
}

/// The forward pass: every parameter's twist `(ω_j, v_j)` into `twists`, and the last frame.
#[inline]
fn walk_twists(
    chain: &[Factor],
    motion: impl Fn(&Factor, usize) -> Motion,
    twists: &mut [[f64; 6]],
) -> Frame {
    for t in twists.iter_mut() {
        *t = [0.0; 6];
    }
    let mut f = Frame::IDENTITY;
    for (i, factor) in chain.iter().enumerate() {
        if factor.terms.iter().any(Option::is_some) {
            let w = f.r[factor.axis.index()];
            let (omega, v) = if factor.rotation {
                (w, cross(&f.o, &w))
            } else {
                ([0.0; 3], w)
            };
            for t in factor.terms.iter().flatten() {
                let tw = &mut twists[t.param];
                for k in 0..3 {
                    tw[k] += t.coef * omega[k];
                    tw[3 + k] += t.coef * v[k];
                }
            }
        }
        f.apply(factor, motion(factor, i));
    }
    f
}

/// The tool frame at `q` and `p` (as [`pose_prepared`], without a prepared table).
pub fn pose(chain: &[Factor], q: &[f64], p: &[f64], tip: &mut [f64; 3], rot: &mut [f64; 9]) {
    let mut f = Frame::IDENTITY;
    for factor in chain {
        f.apply(factor, Motion::of(factor, factor.amount(q, p)));
    }
    *tip = f.o;
    for c in 0..3 {
        rot[3 * c..3 * c + 3].copy_from_slice(&f.r[c]);
    }
}

/// The tool frame at `q` and `p`, and in `twists` each joint's twist `(ω_k, v_k)` in the
/// world at that reading: `Σ (w, o × w)` over the rotations it drives, `Σ (0, w)` over the
/// translations (a reading adds with coefficient 1 to its factor's amount). The joint
/// Jacobians of the tip and of the frame are read from them.
fn joint_twists(chain: &[Factor], q: &[f64], p: &[f64], twists: &mut [[f64; 6]]) -> Frame {
    joint_twists_with(
        chain,
        |factor, _| Motion::of(factor, factor.amount(q, p)),
        twists,
    )
}

/// [`joint_twists`] with each factor's motion from `motion(factor, index)`.
fn joint_twists_with(
    chain: &[Factor],
    mut motion: impl FnMut(&Factor, usize) -> Motion,
    twists: &mut [[f64; 6]],
) -> Frame {
    for t in twists.iter_mut() {
        *t = [0.0; 6];
    }
    let mut f = Frame::IDENTITY;
    for (index, factor) in chain.iter().enumerate() {
        if let Some(k) = factor.joint {
            let w = f.r[factor.axis.index()];
            let (omega, v) = if factor.rotation {
                (w, cross(&f.o, &w))
            } else {
                ([0.0; 3], w)
            };
            let tw = &mut twists[k];
            for c in 0..3 {
                tw[c] += omega[c];
                tw[3 + c] += v[c];
            }
        }
        f.apply(factor, motion(factor, index));
    }
    f
}

/// The tip and its exact Jacobian with respect to the joint readings: `tip` gets `dim`
/// values, `jac` (`dim × J`, row-major, `jac[i*J + k] = ∂x_i/∂q_k`, `J = twists.len()` the
/// joint count) is overwritten; `twists` is scratch of `J` entries.
///
/// The same twists as for the parameters (see the module docs): a joint's reading adds with
/// coefficient 1 to its factor's amount, so joint `k` carries the twist
/// `(ω_k, v_k) = Σ (w, o × w)` (rotations) `+ Σ (0, w)` (translations) over the factors it
/// drives, and `∂x/∂q_k = v_k + ω_k × x`.
///
/// # Panics
/// If a buffer is shorter than stated or a factor names a joint `≥ J` (a programming error).
pub fn tip_joint_jacobian(
    chain: &[Factor],
    dim: usize,
    q: &[f64],
    p: &[f64],
    tip: &mut [f64],
    jac: &mut [f64],
    twists: &mut [[f64; 6]],
) {
    let f = joint_twists(chain, q, p, twists);
    let nj = twists.len();
    tip[..dim].copy_from_slice(&f.o[..dim]);
    for (k, tw) in twists.iter().enumerate() {
        let wx = cross(&[tw[0], tw[1], tw[2]], &f.o);
        for i in 0..dim {
            jac[i * nj + k] = tw[3 + i] + wx[i];
        }
    }
}

/// The tool frame of a spatial chain: its origin `tip` (3 values) and rotation `rot`
/// (column-major, `rot[3c + i]` = component `i` of the frame's axis `c`), from a
/// [`prepare`]d table for the pose `q`.
pub fn pose_prepared<'r>(
    chain: &[Factor],
    motions: &[Motion],
    q: impl Into<Readings<'r>>,
    tip: &mut [f64; 3],
    rot: &mut [f64; 9],
) {
    let r = q.into();
    let mut f = Frame::IDENTITY;
    for (factor, &m) in chain.iter().zip(motions) {
        f.apply(factor, posed(factor, m, &r));
    }
    *tip = f.o;
    for c in 0..3 {
        rot[3 * c..3 * c + 3].copy_from_slice(&f.r[c]);
    }
}

/// The tool frame (as [`pose_prepared`]) and its exact Jacobian, `jac` (`6 × P`, row-major):
/// rows 0-2 `∂x/∂p_j = v_j + ω_j × x`, rows 3-5 the world angular velocity `ω_j` of the frame
/// per unit of `p_j` (see the module docs); `twists` is scratch of `P` entries.
///
/// # Panics
/// If a buffer is shorter than stated (a programming error).
pub fn pose_jacobian_prepared<'r>(
    chain: &[Factor],
    motions: &[Motion],
    q: impl Into<Readings<'r>>,
    tip: &mut [f64; 3],
    rot: &mut [f64; 9],
    jac: &mut [f64],
    twists: &mut [[f64; 6]],
) {
    let r = q.into();
    let f = walk_twists(chain, |factor, i| posed(factor, motions[i], &r), twists);
    let np = twists.len();
    *tip = f.o;
    for c in 0..3 {
        rot[3 * c..3 * c + 3].copy_from_slice(&f.r[c]);
    }
    for (j, tw) in twists.iter().enumerate() {
        let w = [tw[0], tw[1], tw[2]];
        let wx = cross(&w, &f.o);
        for i in 0..3 {
            jac[i * np + j] = tw[3 + i] + wx[i];
            jac[(3 + i) * np + j] = w[i];
        }
    }
}

/// The tool frame at `q` (the parameters those of a [`prepare`]d table) and its exact
/// Jacobian with respect to the joint readings: `jac` (`6 × J`, row-major, `J = twists.len()`
/// the joint count) gets rows 0-2 `∂x/∂q_k = v_k + ω_k × x` and rows 3-5 the world angular
/// velocity `ω_k` of the frame per unit of `q_k` (zero for a prismatic joint), as
/// [`tip_joint_jacobian`] does for the tip; `twists` is scratch of `J` entries. `rot` is
/// column-major as in [`pose`]. From the prepared table only the joints' factors take a sine
/// and cosine: an inverse-kinematics solve evaluates one parameter vector at many readings.
///
/// # Panics
/// If a buffer is shorter than stated or a factor names a joint `≥ J` (a programming error).
pub fn pose_joint_jacobian_prepared(
    chain: &[Factor],
    motions: &[Motion],
    q: &[f64],
    tip: &mut [f64; 3],
    rot: &mut [f64; 9],
    jac: &mut [f64],
    twists: &mut [[f64; 6]],
) {
    let r = Readings { q, trig: None };
    let f = joint_twists_with(chain, |factor, i| posed(factor, motions[i], &r), twists);
    frame_joint_jacobian(&f, tip, rot, jac, twists);
}

/// The tool frame `f` into `tip`, `rot` and the joint Jacobian from the joints' `twists`.
fn frame_joint_jacobian(
    f: &Frame,
    tip: &mut [f64; 3],
    rot: &mut [f64; 9],
    jac: &mut [f64],
    twists: &[[f64; 6]],
) {
    *tip = f.o;
    for c in 0..3 {
        rot[3 * c..3 * c + 3].copy_from_slice(&f.r[c]);
    }
    let nj = twists.len();
    for (k, tw) in twists.iter().enumerate() {
        let w = [tw[0], tw[1], tw[2]];
        let wx = cross(&w, &f.o);
        for i in 0..3 {
            jac[i * nj + k] = tw[3 + i] + wx[i];
            jac[(3 + i) * nj + k] = w[i];
        }
    }
}

/// A joint's frame: the frame just before its factor, fixed to the link the joint is mounted
/// on ([`joint_frames`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointFrame {
    /// The frame's origin, a point on the joint's axis (world coordinates).
    pub origin: [f64; 3],
    /// The frame's axes by columns (`rot[c]` is axis `c` in world coordinates).
    pub rot: [[f64; 3]; 3],
    /// The joint's axis direction (one of `rot`).
    pub axis: [f64; 3],
}

/// The tip `x(q; p)` (returned) and each joint's frame (`frames[i]`, every joint of the chain
/// in order): the frame about whose origin a misplacement of that joint's mounting turns the
/// rest of the arm (the weak-direction prior's frames, `calibrate::prior`).
///
/// # Panics
/// If `frames` is shorter than the chain's joint count (a programming error).
pub fn joint_frames(chain: &[Factor], q: &[f64], p: &[f64], frames: &mut [JointFrame]) -> [f64; 3] {
    let mut f = Frame::IDENTITY;
    for factor in chain {
        if let Some(i) = factor.joint {
            frames[i] = JointFrame {
                origin: f.o,
                rot: f.r,
                axis: f.r[factor.axis.index()],
            };
        }
        f.apply(factor, Motion::of(factor, factor.amount(q, p)));
    }
    f.o
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::spec::chain::Chain;
    use crate::spec::from_yaml_str;
    use crate::spec::kinematics::Kinematics;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const SPECS: &[&str] = &[
        "name: mixed\ndim: 3\nconvention: mdh\njoints:\n  \
         - {type: revolute, a: 0, alpha: 0, d: d1, home: th1}\n  \
         - {type: revolute, a: a2, alpha: pi/2, beta: be2, home: th2}\n  \
         - {type: prismatic, a: a3, alpha: tw, beta: 0.05, theta: 0.2, offset: o3}\n  \
         - {type: revolute, a: 0.1, alpha: 2*pi/3, d: d1, home: 0.3}\n\
         tool: [tx, 0, L]\nbase: {x: bx, y: 0.2, z: 0, roll: rl, pitch: 0.1, yaw: yw}\n\
         params:\n  d1: {nominal: 0.3}\n  th1: {nominal: 0.01}\n  a2: {nominal: 0.4}\n  \
         be2: {nominal: 0.02}\n  \
         th2: {nominal: -0.02}\n  a3: {nominal: 0.05}\n  tw: {nominal: 0.7, known: true}\n  \
         o3: {nominal: 0.1}\n  tx: {nominal: 0.02}\n  L: {nominal: 0.1}\n  \
         bx: {nominal: 0.5}\n  yw: {nominal: 0.1}\n  rl: {nominal: -0.1}\n  cx: {nominal: 0.4}\n  \
         cy: {nominal: 0.1}\n  cz: {nominal: 0.2}\n  r: {nominal: 0.15}\n\
         constraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n",
        "name: dh\ndim: 3\njoints:\n  - {type: revolute, a: a1, alpha: al1, d: d1, home: th1}\n  \
         - {type: revolute, a: a2, alpha: al2, beta: be2, d: d2, home: th2}\n  \
         - {type: prismatic, a: a3, alpha: al3, theta: th3, offset: o3}\n\
         tool: [t1, t2, t3]\nparams:\n  a1: {nominal: 0.1}\n  al1: {nominal: 1.5}\n  \
         be2: {nominal: -0.03}\n  \
         d1: {nominal: 0.3}\n  th1: {nominal: 0}\n  a2: {nominal: 0.4}\n  al2: {nominal: 0.1}\n  \
         d2: {nominal: 0.05}\n  th2: {nominal: 0.2}\n  a3: {nominal: 0.02}\n  \
         al3: {nominal: -0.3}\n  th3: {nominal: 0.4}\n  o3: {nominal: 0.1}\n  \
         t1: {nominal: 0.01}\n  t2: {nominal: 0.02}\n  t3: {nominal: 0.1}\n\
         constraint:\n  measured: {}\n",
        "name: planar\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
         - {type: revolute, a: a2, home: th2}\ntool: [t1, 0.05]\nparams:\n  a1: {nominal: 0.375}\n  \
         a2: {nominal: 0.425}\n  th1: {nominal: 0}\n  th2: {nominal: 0}\n  t1: {nominal: 0.01}\n  \
         b1: {nominal: -1.8}\n  b2: {nominal: -0.5}\nconstraint:\n  line: {b: [b1, b2]}\n",
    ];

    #[test]
    fn pose_jacobian_matches_central_differences_of_the_tool_frame() {
        // A tool frame and a base with unknown angles: every kind of factor moves the frame.
        let text = "name: pose\ndim: 3\nconvention: mdh\njoints:\n  \
             - {type: revolute, a: 0, alpha: 0, d: d1, home: th1}\n  \
             - {type: revolute, a: a2, alpha: al2, home: th2}\n  \
             - {type: prismatic, a: a3, alpha: pi/2, theta: 0.2, offset: o3}\n\
             tool: {x: tx, y: 0.02, z: tz, roll: tr, pitch: tp, yaw: ty}\n\
             base: {x: bx, y: 0.2, z: 0, roll: br, pitch: 0.1, yaw: byaw}\n\
             params:\n  d1: {nominal: 0.3}\n  th1: {nominal: 0.01}\n  a2: {nominal: 0.4}\n  \
             al2: {nominal: 0.1}\n  th2: {nominal: -0.02}\n  a3: {nominal: 0.05}\n  \
             o3: {nominal: 0.1}\n  tx: {nominal: 0.02}\n  tz: {nominal: 0.1}\n  \
             tr: {nominal: 0.1}\n  tp: {nominal: -0.2}\n  ty: {nominal: 0.3}\n  \
             bx: {nominal: 0.5}\n  br: {nominal: -0.1}\n  byaw: {nominal: 0.1}\n\
             constraint: measured_pose\n";
        let spec = from_yaml_str(text, None).unwrap();
        let chain = Chain::from_spec(&spec);
        let kin = Kinematics::new(&spec);
        let (n, np) = (spec.joints.len(), spec.estimated_params().len());
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let mut tw = vec![[0.0; 6]; np];
        let mut motions = vec![Motion::default(); chain.factors.len()];
        for _ in 0..20 {
            let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
            let p: Vec<f64> = (0..np).map(|_| rng.gen_range(-1.0..1.0)).collect();
            prepare(&chain.factors, &p, &mut motions);
            // The frame from the readings' sines and cosines is the same frame.
            let mut trig = Vec::new();
            reading_trig(&q, &mut trig);
            let (mut x2, mut rot2) = ([0.0; 3], [0.0; 9]);
            let r = Readings {
                q: &q,
                trig: Some(&trig),
            };
            pose_prepared(&chain.factors, &motions, r, &mut x2, &mut rot2);
            let (mut x, mut rot, mut jac) = ([0.0; 3], [0.0; 9], vec![0.0; 6 * np]);
            pose_jacobian_prepared(
                &chain.factors,
                &motions,
                &q,
                &mut x,
                &mut rot,
                &mut jac,
                &mut tw,
            );
            for (a, b) in x.iter().chain(&rot).zip(x2.iter().chain(&rot2)) {
                assert!((a - b).abs() < 1e-13, "frame from trig {a} vs {b}");
            }
            // The origin is the reference tip; the rotation orthonormal.
            let mut want = [0.0; 3];
            kin.tip(&q, &p, &mut want);
            for (a, b) in x.iter().zip(&want) {
                assert!((a - b).abs() < 1e-13, "tip {a} vs {b}");
            }
            let rtr = crate::model::rotation::transpose_times(&rot, &rot);
            for (k, v) in rtr.iter().enumerate() {
                let e = if k % 4 == 0 { 1.0 } else { 0.0 };
                assert!((v - e).abs() < 1e-13);
            }
            for j in 0..np {
                let h = 1e-6;
                let (mut pp, mut pm) = (p.clone(), p.clone());
                pp[j] += h;
                pm[j] -= h;
                let (mut xp, mut rp, mut xm, mut rm) = ([0.0; 3], [0.0; 9], [0.0; 3], [0.0; 9]);
                pose(&chain.factors, &q, &pp, &mut xp, &mut rp);
                pose(&chain.factors, &q, &pm, &mut xm, &mut rm);
                // dR·Rᵀ = [ω]ₓ: ω from the skew part of the central difference.
                let d: [f64; 9] = core::array::from_fn(|k| (rp[k] - rm[k]) / (2.0 * h));
                // (dR Rᵀ)_ab = Σ_c dR_ac R_bc, column-major storage r[3c + i].
                let w = |a: usize, b: usize| -> f64 {
                    (0..3).map(|c| d[3 * c + a] * rot[3 * c + b]).sum()
                };
                let omega = [w(2, 1), w(0, 2), w(1, 0)];
                for i in 0..3 {
                    let fd = (xp[i] - xm[i]) / (2.0 * h);
                    assert!((fd - jac[i * np + j]).abs() < 1e-8, "dx{i}/dp{j}");
                    assert!(
                        (omega[i] - jac[(3 + i) * np + j]).abs() < 1e-8,
                        "omega{i}/dp{j}: {} vs {}",
                        jac[(3 + i) * np + j],
                        omega[i]
                    );
                }
            }
        }
    }

    #[test]
    fn tip_and_jacobian_match_the_dh_product_and_central_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for text in SPECS {
            let spec = from_yaml_str(text, None).unwrap();
            let chain = Chain::from_spec(&spec);
            let kin = Kinematics::new(&spec);
            let (n, np, dim) = (spec.joints.len(), spec.estimated_params().len(), spec.dim);
            let mut tw = vec![[0.0; 6]; np];
            for _ in 0..20 {
                let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
                let p: Vec<f64> = (0..np).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let (mut want, mut got) = (vec![0.0; dim], vec![0.0; dim]);
                kin.tip(&q, &p, &mut want);
                let mut jac = vec![0.0; dim * np];
                tip_jacobian(&chain.factors, dim, &q, &p, &mut got, &mut jac, &mut tw);
                for (a, b) in got.iter().zip(&want) {
                    assert!((a - b).abs() < 1e-13, "{}: tip {a} vs {b}", spec.name);
                }
                tip(&chain.factors, dim, &q, &p, &mut got);
                for (a, b) in got.iter().zip(&want) {
                    assert!((a - b).abs() < 1e-13, "{}: tip {a} vs {b}", spec.name);
                }
                // The prepared path: the same tip and Jacobian.
                let mut motions = vec![Motion::default(); chain.factors.len()];
                prepare(&chain.factors, &p, &mut motions);
                tip_prepared(&chain.factors, &motions, dim, &q, &mut got);
                for (a, b) in got.iter().zip(&want) {
                    assert!(
                        (a - b).abs() < 1e-13,
                        "{}: prepared tip {a} vs {b}",
                        spec.name
                    );
                }
                // With the readings' sines and cosines known (angle addition) and without.
                let mut trig = Vec::new();
                reading_trig(&q, &mut trig);
                let with_trig = Readings {
                    q: &q,
                    trig: Some(&trig),
                };
                tip_prepared(&chain.factors, &motions, dim, with_trig, &mut got);
                for (a, b) in got.iter().zip(&want) {
                    assert!((a - b).abs() < 1e-13, "{}: tip from trig", spec.name);
                }
                for r in [Readings::from(&q), with_trig] {
                    let mut jac2 = vec![0.0; dim * np];
                    tip_jacobian_prepared(
                        &chain.factors,
                        &motions,
                        dim,
                        r,
                        &mut got,
                        &mut jac2,
                        &mut tw,
                    );
                    for (a, b) in jac2.iter().zip(&jac) {
                        assert!(
                            (a - b).abs() < 1e-13,
                            "{}: prepared ∂x/∂p {a} vs {b}",
                            spec.name
                        );
                    }
                }
                for j in 0..np {
                    let h = 1e-6;
                    let (mut pp, mut pm) = (p.clone(), p.clone());
                    pp[j] += h;
                    pm[j] -= h;
                    let (mut xp, mut xm) = (vec![0.0; dim], vec![0.0; dim]);
                    kin.tip(&q, &pp, &mut xp);
                    kin.tip(&q, &pm, &mut xm);
                    for i in 0..dim {
                        let fd = (xp[i] - xm[i]) / (2.0 * h);
                        let ex = jac[i * np + j];
                        assert!(
                            (fd - ex).abs() < 1e-8,
                            "{}: d x{i}/d p{j}: {ex} vs {fd}",
                            spec.name
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn joint_jacobian_matches_central_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        for text in SPECS {
            let spec = from_yaml_str(text, None).unwrap();
            let chain = Chain::from_spec(&spec);
            let (n, np, dim) = (spec.joints.len(), spec.estimated_params().len(), spec.dim);
            let mut tw = vec![[0.0; 6]; n];
            for _ in 0..20 {
                let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
                let p: Vec<f64> = (0..np).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let (mut want, mut got) = (vec![0.0; dim], vec![0.0; dim]);
                tip(&chain.factors, dim, &q, &p, &mut want);
                let mut jac = vec![0.0; dim * n];
                tip_joint_jacobian(&chain.factors, dim, &q, &p, &mut got, &mut jac, &mut tw);
                assert_eq!(got, want, "{}: tip", spec.name);
                for k in 0..n {
                    let h = 1e-6;
                    let (mut qp, mut qm) = (q.clone(), q.clone());
                    qp[k] += h;
                    qm[k] -= h;
                    let (mut xp, mut xm) = (vec![0.0; dim], vec![0.0; dim]);
                    tip(&chain.factors, dim, &qp, &p, &mut xp);
                    tip(&chain.factors, dim, &qm, &p, &mut xm);
                    for i in 0..dim {
                        let fd = (xp[i] - xm[i]) / (2.0 * h);
                        let ex = jac[i * n + k];
                        assert!(
                            (fd - ex).abs() < 1e-8,
                            "{}: d x{i}/d q{k}: {ex} vs {fd}",
                            spec.name
                        );
                    }
                }
            }
        }
    }
}
