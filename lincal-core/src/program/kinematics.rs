//! The numeric programs straight from the spec: the forward kinematics `tip(q, p)` as a
//! product of DH transforms (slots resolved to estimated parameters or exact constants,
//! right angles exact), and every constraint's values `constraint_values(p)`.

use super::builder::Builder;
use super::straight_line::{LinComb, Program};
use crate::spec::{Base, Convention, Exact, JointKind, RowForm, Slot, Spec};

/// How a slot enters the numeric programs.
enum SlotValue {
    /// An exact constant (or a known parameter's nominal).
    Exact(Exact),
    /// Estimated parameter `j`.
    Param(usize),
}

fn slot_value(spec: &Spec, estimated: &[String], s: &Slot) -> SlotValue {
    match s {
        Slot::Const(e) => SlotValue::Exact(e.clone()),
        Slot::Param(name) => match estimated.iter().position(|n| n == name) {
            Some(j) => SlotValue::Param(j),
            None => SlotValue::Exact(
                spec.param(name)
                    .map_or_else(Exact::zero, |p| p.nominal.clone()),
            ),
        },
    }
}

/// Numeric program context: the builder and the slot resolution.
struct Numeric<'a> {
    b: Builder,
    spec: &'a Spec,
    estimated: Vec<String>,
}

/// A 3×4 affine transform `[R | t]` of affine combinations.
type Affine = [[LinComb; 4]; 3];

impl Numeric<'_> {
    fn new(spec: &Spec) -> Numeric<'_> {
        Numeric {
            b: Builder::default(),
            spec,
            estimated: spec
                .estimated_params()
                .iter()
                .map(|p| p.name.clone())
                .collect(),
        }
    }

    fn length(&mut self, s: &Slot) -> LinComb {
        match slot_value(self.spec, &self.estimated, s) {
            SlotValue::Exact(e) => LinComb::constant(e.to_f64()),
            SlotValue::Param(j) => LinComb::value(self.b.p(j)),
        }
    }

    /// `(cos, sin)` of an angle slot; exact for multiples of π/2.
    fn angle(&mut self, s: &Slot) -> (LinComb, LinComb) {
        match slot_value(self.spec, &self.estimated, s) {
            SlotValue::Exact(e) => exact_cos_sin(&e),
            SlotValue::Param(j) => {
                let x = self.b.p(j);
                (LinComb::value(self.b.cos(x)), LinComb::value(self.b.sin(x)))
            }
        }
    }

    /// `(cos θ, sin θ)` of `θ = q_i − home`.
    fn joint_angle(&mut self, i: usize, home: &Slot) -> (LinComb, LinComb) {
        let q = LinComb::value(self.b.q(i));
        match slot_value(self.spec, &self.estimated, home) {
            SlotValue::Exact(e) if e.exact_cos_sin().is_some() => {
                // cos(q − h) = cos q·cos h + sin q·sin h; sin(q − h) = sin q·cos h − cos q·sin h
                let (ch, sh) = exact_cos_sin(&e);
                let (cq, sq) = (self.b.cos_of(&q), self.b.sin_of(&q));
                let c = cq.scale(ch.constant).add_scaled(&sq, sh.constant);
                let s = sq.scale(ch.constant).add_scaled(&cq, -sh.constant);
                (c, s)
            }
            SlotValue::Exact(e) => {
                let theta = q.add_scaled(&LinComb::constant(e.to_f64()), -1.0);
                (self.b.cos_of(&theta), self.b.sin_of(&theta))
            }
            SlotValue::Param(j) => {
                let theta = q.add_scaled(&LinComb::value(self.b.p(j)), -1.0);
                (self.b.cos_of(&theta), self.b.sin_of(&theta))
            }
        }
    }

    fn compose(&mut self, a: &Affine, b: &Affine) -> Affine {
        let mut r: Affine = Default::default();
        for i in 0..3 {
            for j in 0..4 {
                let mut acc = if j == 3 {
                    a[i][3].clone()
                } else {
                    LinComb::default()
                };
                for k in 0..3 {
                    let t = self.b.times(&a[i][k], &b[k][j]);
                    acc = self.b.add(&acc, &t);
                }
                r[i][j] = acc;
            }
        }
        r
    }
}

fn exact_cos_sin(e: &Exact) -> (LinComb, LinComb) {
    match e.exact_cos_sin() {
        Some((c, s)) => (
            LinComb::constant(f64::from(c)),
            LinComb::constant(f64::from(s)),
        ),
        None => {
            let x = e.to_f64();
            (LinComb::constant(x.cos()), LinComb::constant(x.sin()))
        }
    }
}

fn c(x: f64) -> LinComb {
    LinComb::constant(x)
}

fn identity() -> Affine {
    let mut r: Affine = Default::default();
    for (i, row) in r.iter_mut().enumerate() {
        row[i] = c(1.0);
    }
    r
}

fn rot_z(cs: &(LinComb, LinComb)) -> Affine {
    let (co, si) = cs;
    [
        [co.clone(), si.scale(-1.0), c(0.0), c(0.0)],
        [si.clone(), co.clone(), c(0.0), c(0.0)],
        [c(0.0), c(0.0), c(1.0), c(0.0)],
    ]
}

fn rot_x(cs: &(LinComb, LinComb)) -> Affine {
    let (co, si) = cs;
    [
        [c(1.0), c(0.0), c(0.0), c(0.0)],
        [c(0.0), co.clone(), si.scale(-1.0), c(0.0)],
        [c(0.0), si.clone(), co.clone(), c(0.0)],
    ]
}

fn rot_y(cs: &(LinComb, LinComb)) -> Affine {
    let (co, si) = cs;
    [
        [co.clone(), c(0.0), si.clone(), c(0.0)],
        [c(0.0), c(1.0), c(0.0), c(0.0)],
        [si.scale(-1.0), c(0.0), co.clone(), c(0.0)],
    ]
}

fn translate(x: LinComb, y: LinComb, z: LinComb) -> Affine {
    let mut r = identity();
    r[0][3] = x;
    r[1][3] = y;
    r[2][3] = z;
    r
}

/// `Tr(x, y, z)·Rz(yaw)·Ry(pitch)·Rx(roll)` of a frame's slots (the base, a joint's origin).
fn frame(n: &mut Numeric<'_>, b: &Base) -> Affine {
    let (x, y, z) = (n.length(&b.x), n.length(&b.y), n.length(&b.z));
    let (roll, pitch, yaw) = (n.angle(&b.roll), n.angle(&b.pitch), n.angle(&b.yaw));
    let m = n.compose(&translate(x, y, z), &rot_z(&yaw));
    let m = n.compose(&m, &rot_y(&pitch));
    n.compose(&m, &rot_x(&roll))
}

/// The forward kinematics `x(q; p)` as a numeric DH product (the conventions of
/// [`crate::spec::kinematics`]): `B·A_1⋯A_n·(tool, 1)`, the first `dim` rows.
pub(super) fn tip_program(spec: &Spec) -> Program {
    let mut n = Numeric::new(spec);
    let mut t = match &spec.base {
        Some(base) => frame(&mut n, base),
        None => identity(),
    };
    for (i, j) in spec.joints.iter().enumerate() {
        if spec.convention == Convention::Urdf {
            let origin = frame(&mut n, &j.origin);
            t = n.compose(&t, &origin);
        }
        let (theta, d) = match j.kind {
            JointKind::Revolute => (n.joint_angle(i, &j.home), n.length(&j.d)),
            JointKind::Prismatic => {
                let q = LinComb::value(n.b.q(i));
                let d = q.add_scaled(&n.length(&j.offset), 1.0);
                let d = d.add_scaled(&n.length(&j.d), 1.0);
                (n.angle(&j.theta), d)
            }
        };
        let a = n.length(&j.a);
        let alpha = n.angle(&j.alpha);
        let tz = translate(c(0.0), c(0.0), d);
        let tx = translate(a, c(0.0), c(0.0));
        // Hayati's tilt right after the twist, when there is one.
        let tilt = (j.beta != Slot::zero()).then(|| rot_y(&n.angle(&j.beta)));
        let factors: Vec<Affine> = match spec.convention.row() {
            RowForm::Dh => [rot_z(&theta), tz, tx, rot_x(&alpha)]
                .into_iter()
                .chain(tilt)
                .collect(),
            RowForm::Mdh => std::iter::once(rot_x(&alpha))
                .chain(tilt)
                .chain([tx, rot_z(&theta), tz])
                .collect(),
        };
        for f in &factors {
            t = n.compose(&t, f);
        }
    }
    let mut tool = [c(0.0), c(0.0), c(0.0)];
    for (k, s) in spec.tool.iter().enumerate().take(3) {
        tool[k] = n.length(s);
    }
    let mut outputs = Vec::new();
    for row in t.iter().take(spec.dim) {
        let mut acc = row[3].clone();
        for (k, tk) in tool.iter().enumerate() {
            let prod = n.b.times(&row[k], tk);
            acc = n.b.add(&acc, &prod);
        }
        outputs.push(acc);
    }
    n.b.finish(outputs)
}

/// Every constraint's values (canonical order), concatenated.
pub(super) fn constraint_program(spec: &Spec) -> Program {
    let mut n = Numeric::new(spec);
    let mut outputs = Vec::new();
    for con in &spec.constraints {
        for s in con.slots() {
            let v = n.length(s);
            outputs.push(v);
        }
    }
    n.b.finish(outputs)
}
