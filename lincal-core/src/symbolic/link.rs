//! One link of the chain as a rigid transform with polynomial entries: the DH row of a joint
//! (standard or modified), with Hayati's tilt `β` when it has one, for the expansion
//! ([`super::expand`]).

use super::chain_poly::ChainPoly;
use super::poly::Poly;
use crate::error::Result;
#[cfg(doc)]
use crate::spec::Convention;
use crate::spec::RowForm;

std::thread_local! {
    /// Set on a thread that expands beside other work (the basis built ahead,
    /// [`super::prefetch`]): its products stay on it rather than taking the other core.
    pub(super) static SERIAL: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// A rigid transform `v ↦ R v + t` with polynomial entries (exact, or a sketch's).
pub(super) struct Transform<P = Poly> {
    pub(super) r: [[P; 3]; 3],
    pub(super) t: [P; 3],
    /// `(Rᵀt, ‖t‖²)` as polynomials of their own, for a span-equivalent link
    /// ([`super::surrogate`]) whose `R` is not a rotation; `None`: from `R` and `t`.
    pub(super) norm: Option<Box<([P; 3], P)>>,
}

impl<P> Transform<P> {
    /// Each entry's image under `f`; `None` as soon as one has none.
    pub(super) fn try_map<Q>(&self, f: &mut impl FnMut(&P) -> Option<Q>) -> Option<Transform<Q>> {
        let [r0, r1, r2] = &self.r;
        let norm = match &self.norm {
            Some(nm) => Some(Box::new((try_map3(&nm.0, f)?, f(&nm.1)?))),
            None => None,
        };
        Some(Transform {
            r: [try_map3(r0, f)?, try_map3(r1, f)?, try_map3(r2, f)?],
            t: try_map3(&self.t, f)?,
            norm,
        })
    }
}

/// Each of three entries' image under `f`; `None` as soon as one has none.
pub(super) fn try_map3<P, Q>(v: &[P; 3], f: &mut impl FnMut(&P) -> Option<Q>) -> Option<[Q; 3]> {
    Some([f(&v[0])?, f(&v[1])?, f(&v[2])?])
}

impl<P: ChainPoly> Transform<P> {
    pub(super) fn apply(&self, v: &[P; 3], pairs: &P::Ctx) -> Result<[P; 3]> {
        self.apply_with(v, true, pairs)
    }

    /// `R v`: a direction carried through the transform (the tool frame's axes).
    pub(super) fn rotate(&self, v: &[P; 3], pairs: &P::Ctx) -> Result<[P; 3]> {
        self.apply_with(v, false, pairs)
    }

    /// `R v + t` (`translate`) or `R v`.
    fn apply_with(&self, v: &[P; 3], translate: bool, pairs: &P::Ctx) -> Result<[P; 3]> {
        // Each row accumulated in place, its table sized once for every product term.
        let row = |i: usize| -> Result<P> {
            let mut acc = if translate {
                self.t[i].clone()
            } else {
                P::default()
            };
            let products: usize = v
                .iter()
                .enumerate()
                .map(|(j, vj)| self.r[i][j].len() * vj.len())
                .sum();
            acc.reserve(products);
            for (j, vj) in v.iter().enumerate() {
                acc.add_product(&self.r[i][j], vj, pairs)?;
            }
            Ok(acc)
        };
        if v.iter().map(P::len).sum::<usize>() < 2_000 || SERIAL.with(std::cell::Cell::get) {
            return Ok([row(0)?, row(1)?, row(2)?]);
        }
        // Near the base the products are large: the third row on the other core.
        let ((a, b), c) = crate::cores::join(|| (row(0), row(1)), || row(2));
        Ok([a?, b?, c?])
    }
}

impl<P: ChainPoly> Transform<P> {
    /// The product `self · next`: `R = R_s·R_n`, `t = R_s·t_n + t_s` (a joint's origin and
    /// its row in [`Convention::Urdf`]).
    pub(super) fn then(&self, next: &Transform<P>, pairs: &P::Ctx) -> Result<Transform<P>> {
        let t = self.apply(&next.t, pairs)?;
        let column = |c: usize| -> Result<[P; 3]> {
            let col = [
                next.r[0][c].clone(),
                next.r[1][c].clone(),
                next.r[2][c].clone(),
            ];
            self.rotate(&col, pairs)
        };
        let cols = [column(0)?, column(1)?, column(2)?];
        let r = std::array::from_fn(|i| std::array::from_fn(|c| cols[c][i].clone()));
        Ok(Transform { r, t, norm: None })
    }

    /// `‖R v + t‖²` from `n = ‖v‖²`: `n + 2 (Rᵀt)·v + ‖t‖²`, as `R` is a rotation. Only
    /// products with the small `t` and `Rᵀt`, where squaring the tip would multiply two
    /// large polynomials (the identity holds exactly in canonical form, which is unique).
    pub(super) fn norm2_after(&self, v: &[P; 3], n: &P, pairs: &P::Ctx) -> Result<P> {
        let mut out = n.clone();
        if let Some(nm) = &self.norm {
            let (rt, tt) = &**nm;
            for (u, vj) in rt.iter().zip(v) {
                if !u.is_zero() && !vj.is_zero() {
                    out = out.add(&m(u, vj, pairs)?.scale_int(2));
                }
            }
            return Ok(out.add(tt));
        }
        for (j, vj) in v.iter().enumerate() {
            if vj.is_zero() {
                continue;
            }
            let mut rt = P::default();
            for i in 0..3 {
                if !self.r[i][j].is_zero() && !self.t[i].is_zero() {
                    rt = rt.add(&m(&self.r[i][j], &self.t[i], pairs)?);
                }
            }
            if !rt.is_zero() {
                out = out.add(&m(&rt, vj, pairs)?.scale_int(2));
            }
        }
        for ti in &self.t {
            if !ti.is_zero() {
                out = out.add(&ti.square(pairs)?);
            }
        }
        Ok(out)
    }
}

/// The index of `x_i·x_j` (`i ≤ j`) among the tip's second moments `X = x xᵀ`, upper triangle
/// row by row: `00, 01, 02, 11, 12, 22`.
pub(super) const fn moment(i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    i * 3 - i * (i + 1) / 2 + j
}

impl<P: ChainPoly> Transform<P> {
    /// A bound on the terms of the largest entry [`Transform::moments_after`] forms from
    /// `v` and `x2`, before it is formed: each product's terms at most the factors' product.
    pub(super) fn predicted_moments(&self, v: &[P; 3], x2: &[P; 6]) -> usize {
        let (r, t) = (&self.r, &self.t);
        let n = |a: &P| a.len();
        let mut worst = 0usize;
        for i in 0..3 {
            for j in i..3 {
                let mut total = n(&t[i]).saturating_mul(n(&t[j]));
                for k in 0..3 {
                    for l in k..3 {
                        let mut c = n(&r[i][k]).saturating_mul(n(&r[j][l]));
                        if k != l {
                            c = c.saturating_add(n(&r[i][l]).saturating_mul(n(&r[j][k])));
                        }
                        total = total.saturating_add(c.saturating_mul(n(&x2[moment(k, l)])));
                    }
                    let c = n(&r[i][k])
                        .saturating_mul(n(&t[j]))
                        .saturating_add(n(&t[i]).saturating_mul(n(&r[j][k])));
                    total = total.saturating_add(c.saturating_mul(n(&v[k])));
                }
                worst = worst.max(total);
            }
        }
        worst
    }

    /// The second moments `X' = x' x'ᵀ` of `x' = R v + t` from `X = v vᵀ` (`x2`, [`moment`]
    /// order): `X'_ij = Σ_kl R_ik R_jl X_kl + Σ_k (R_ik t_j + t_i R_jk) v_k + t_i t_j`. The
    /// coefficients are products of the link's small entries, formed first; each then
    /// multiplies one large `X_kl` or `v_k`, where squaring the tip at the end would multiply
    /// two large polynomials (a quadric's `xᵀAx`). An identity of polynomials for any `R`.
    pub(super) fn moments_after(&self, v: &[P; 3], x2: &[P; 6], pairs: &P::Ctx) -> Result<[P; 6]> {
        let (r, t) = (&self.r, &self.t);
        let mut out: [P; 6] = Default::default();
        for i in 0..3 {
            for j in i..3 {
                let o = &mut out[moment(i, j)];
                if !t[i].is_zero() && !t[j].is_zero() {
                    *o = m(&t[i], &t[j], pairs)?;
                }
                for k in 0..3 {
                    for l in k..3 {
                        let mut c = m(&r[i][k], &r[j][l], pairs)?;
                        if k != l {
                            c.add_assign(&m(&r[i][l], &r[j][k], pairs)?);
                        }
                        let x = &x2[moment(k, l)];
                        if !c.is_zero() && !x.is_zero() {
                            o.add_product(&c, x, pairs)?;
                        }
                    }
                    let mut c = m(&r[i][k], &t[j], pairs)?;
                    c.add_assign(&m(&t[i], &r[j][k], pairs)?);
                    if !c.is_zero() && !v[k].is_zero() {
                        o.add_product(&c, &v[k], pairs)?;
                    }
                }
            }
        }
        Ok(out)
    }
}

/// `a·b`, reduced by the trigonometric pairs `pairs`.
pub(super) fn m<P: ChainPoly>(a: &P, b: &P, pairs: &P::Ctx) -> Result<P> {
    Ok(a.mul(b, pairs)?)
}

/// The DH transform of one link from `cos θ, sin θ, cos α, sin α, a, d`.
#[allow(clippy::too_many_arguments)] // the six DH quantities, the convention and the trig pairs
pub(super) fn dh(
    conv: RowForm,
    ct: &Poly,
    st: &Poly,
    ca: &Poly,
    sa: &Poly,
    a: &Poly,
    d: &Poly,
    pairs: &[(usize, usize)],
) -> Result<Transform> {
    let z = Poly::zero;
    Ok(match conv {
        // Rz(θ)·Tz(d)·Tx(a)·Rx(α)
        RowForm::Dh => Transform {
            r: [
                [ct.clone(), m(st, ca, pairs)?.neg(), m(st, sa, pairs)?],
                [st.clone(), m(ct, ca, pairs)?, m(ct, sa, pairs)?.neg()],
                [z(), sa.clone(), ca.clone()],
            ],
            t: [m(a, ct, pairs)?, m(a, st, pairs)?, d.clone()],
            norm: None,
        },
        // Rx(α)·Tx(a)·Rz(θ)·Tz(d)
        RowForm::Mdh => Transform {
            r: [
                [ct.clone(), st.neg(), z()],
                [m(st, ca, pairs)?, m(ct, ca, pairs)?, sa.neg()],
                [m(st, sa, pairs)?, m(ct, sa, pairs)?, ca.clone()],
            ],
            t: [a.clone(), m(sa, d, pairs)?.neg(), m(ca, d, pairs)?],
            norm: None,
        },
    })
}

/// A DH row with Hayati's tilt `β` ([`crate::spec::Joint::beta`]): DH `Rz(θ)·Tz(d)·Tx(a)·Rx(α)·Ry(β)`,
/// modified DH `Rx(α)·Ry(β)·Tx(a)·Rz(θ)·Tz(d)`. Separate from [`dh`] so that a spec without
/// a tilt expands exactly as before.
pub(super) fn tilted(
    conv: RowForm,
    [ct, st]: [&Poly; 2],
    [ca, sa]: [&Poly; 2],
    [cb, sb]: [&Poly; 2],
    [a, d]: [&Poly; 2],
    pairs: &[(usize, usize)],
) -> Result<Transform> {
    let z = Poly::zero;
    let pm = |x: &Poly, y: &Poly| m(x, y, pairs);
    Ok(match conv {
        RowForm::Dh => {
            // R·Ry(β): the first and last columns mix, the middle one stays.
            let r0 = dh(conv, ct, st, ca, sa, a, d, pairs)?;
            let mut r = r0.r.clone();
            for (row, old) in r.iter_mut().zip(&r0.r) {
                row[0] = pm(cb, &old[0])?.sub(&pm(sb, &old[2])?);
                row[2] = pm(sb, &old[0])?.add(&pm(cb, &old[2])?);
            }
            Transform {
                r,
                t: r0.t,
                norm: None,
            }
        }
        RowForm::Mdh => {
            // A = Rx(α)·Ry(β); then A·Rz(θ) and A·(a, 0, d).
            let am = [
                [cb.clone(), z(), sb.clone()],
                [pm(sa, sb)?, ca.clone(), pm(sa, cb)?.neg()],
                [pm(ca, sb)?.neg(), sa.clone(), pm(ca, cb)?],
            ];
            let mut r: [[Poly; 3]; 3] = Default::default();
            let mut t: [Poly; 3] = Default::default();
            for i in 0..3 {
                r[i][0] = pm(&am[i][0], ct)?.add(&pm(&am[i][1], st)?);
                r[i][1] = pm(&am[i][1], ct)?.sub(&pm(&am[i][0], st)?);
                r[i][2] = am[i][2].clone();
                t[i] = pm(&am[i][0], a)?.add(&pm(&am[i][2], d)?);
            }
            Transform { r, t, norm: None }
        }
    })
}
