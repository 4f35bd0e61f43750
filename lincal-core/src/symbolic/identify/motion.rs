//! A link of the chain as a function of its joint reading, and the tip carried through such
//! links with its gradient over the estimated parameters.
//!
//! A link's transform `[R | t]` is affine in `φ(q) = (1, cos q, sin q)` for a revolute joint
//! and in `φ(q) = (1, q)` for a prismatic one: every DH or MDH entry (tilted or not) is of
//! degree at most one in `cos θ, sin θ` (or in `d`), and a URDF origin multiplies it by a
//! constant transform. So `T(q) = Σ_κ φ_κ(q)·A_κ` with `A_0 = T(φ = e_0)` and
//! `A_κ = T(e_0 + e_κ) − A_0`, each evaluated once per point with its gradient over the link's
//! own parameters ([`Motion`]). A reading then costs a combination of the `A_κ` and one
//! product of `R` with the tip's gradient (`3 × 3 × P`), where forward-mode duals through the
//! link's formulas formed each entry's `P`-long gradient again at every reading.

use super::super::modp::Scalar;
use super::dual::Dual;

/// The entries of a rigid transform: `R` row-major (`0..9`), then `t` (`9..12`).
pub(super) const ENTRIES: usize = 12;

/// A link's transform `T(q) = Σ_κ φ_κ(q)·A_κ`, with the gradients of the `A_κ` over the
/// parameters `params` (those any entry depends on).
pub(super) struct Motion<T> {
    params: Vec<usize>,
    /// Per code `κ`: the entries of `A_κ`.
    values: Vec<[T; ENTRIES]>,
    /// Per code `κ`: `∂A_κ/∂p_{params[l]}` at `[e·ℓ + l]`, `ℓ = params.len()`.
    grads: Vec<Vec<T>>,
}

impl<T: Scalar> Motion<T> {
    /// The motion from its transform at `φ = e_0` (`at[0]`) and at `φ = e_0 + e_κ` (`at[κ]`),
    /// entries as [`ENTRIES`] orders them, gradients over every parameter (or empty: zero).
    pub(super) fn from_points(at: &[[Dual<T>; ENTRIES]]) -> Self {
        let np = at.iter().flatten().map(|d| d.g.len()).max().unwrap_or(0);
        let params: Vec<usize> = (0..np)
            .filter(|&j| {
                at.iter()
                    .flatten()
                    .any(|d| d.g.get(j).is_some_and(|&x| x != T::zero()))
            })
            .collect();
        let grad = |d: &Dual<T>, j: usize| d.g.get(j).copied().unwrap_or_else(T::zero);
        let mut values = Vec::with_capacity(at.len());
        let mut grads = Vec::with_capacity(at.len());
        for (k, point) in at.iter().enumerate() {
            let base = &at[0];
            values.push(std::array::from_fn(|e| {
                if k == 0 {
                    point[e].v
                } else {
                    point[e].v.sub(base[e].v)
                }
            }));
            let mut g = Vec::with_capacity(ENTRIES * params.len());
            for e in 0..ENTRIES {
                for &j in &params {
                    g.push(if k == 0 {
                        grad(&point[e], j)
                    } else {
                        grad(&point[e], j).sub(grad(&base[e], j))
                    });
                }
            }
            grads.push(g);
        }
        Motion {
            params,
            values,
            grads,
        }
    }
}

/// A vector with its gradient: values, and `∂x_a/∂p_j` at `[a·P + j]`.
struct Tracked<T> {
    x: [T; 3],
    g: Vec<T>,
}

impl<T: Scalar> Tracked<T> {
    fn new(v: &[Dual<T>; 3], np: usize) -> Self {
        let mut g = vec![T::zero(); 3 * np];
        for (a, d) in v.iter().enumerate() {
            for (j, &x) in d.g.iter().enumerate().take(np) {
                g[a * np + j] = x;
            }
        }
        Tracked {
            x: std::array::from_fn(|a| v[a].v),
            g,
        }
    }
}

/// The tip (and a measured pose's tool axes, directions) carried from the tool towards the
/// base, each with its gradient over `np` parameters.
pub(super) struct Carried<T> {
    np: usize,
    point: Tracked<T>,
    axes: Vec<Tracked<T>>,
    /// The link's entries at the reading, and their gradients (`ENTRIES × ℓ`).
    entries: [T; ENTRIES],
    local: Vec<T>,
    /// The next gradient, swapped in.
    next: Vec<T>,
}

impl<T: Scalar> Carried<T> {
    /// The tool point, and the tool frame's axes when its pose is measured.
    pub(super) fn new(tool: &[Dual<T>; 3], axes: Option<&[[Dual<T>; 3]; 3]>, np: usize) -> Self {
        Carried {
            np,
            point: Tracked::new(tool, np),
            axes: axes
                .into_iter()
                .flatten()
                .map(|a| Tracked::new(a, np))
                .collect(),
            entries: [T::zero(); ENTRIES],
            local: Vec::new(),
            next: vec![T::zero(); 3 * np],
        }
    }

    /// Carries the tip (and axes) through `m` at the reading's `φ_κ`, `κ ≥ 1` (`phi`).
    pub(super) fn through(&mut self, m: &Motion<T>, phi: &[T]) {
        let nl = m.params.len();
        self.entries = m.values[0];
        self.local.clear();
        self.local.extend_from_slice(&m.grads[0]);
        for (k, &f) in phi.iter().enumerate() {
            for (e, &a) in self.entries.iter_mut().zip(&m.values[k + 1]) {
                *e = e.add(f.mul(a));
            }
            for (e, &a) in self.local.iter_mut().zip(&m.grads[k + 1]) {
                *e = e.add(f.mul(a));
            }
        }
        debug_assert_eq!(self.local.len(), ENTRIES * nl);
        let (entries, local) = (&self.entries, &self.local);
        let moves = std::iter::once((&mut self.point, true))
            .chain(self.axes.iter_mut().map(|a| (a, false)));
        for (v, translate) in moves {
            carry(
                v,
                entries,
                local,
                &m.params,
                translate,
                self.np,
                &mut self.next,
            );
        }
    }

    /// The tip's first `dim` coordinates, then the axes' entries (axis by axis), as duals.
    pub(super) fn into_duals(self, dim: usize) -> Vec<Dual<T>> {
        let np = self.np;
        let dual = |t: &Tracked<T>, a: usize| Dual {
            v: t.x[a],
            g: t.g[a * np..(a + 1) * np].to_vec(),
        };
        let mut out: Vec<Dual<T>> = (0..dim).map(|a| dual(&self.point, a)).collect();
        for axis in &self.axes {
            out.extend((0..3).map(|a| dual(axis, a)));
        }
        out
    }
}

/// `v ← R v (+ t)` with its gradient: `∂(Rv)/∂p = R·∂v/∂p + (∂R/∂p)·v` (the second term on
/// the link's own parameters only).
fn carry<T: Scalar>(
    v: &mut Tracked<T>,
    entries: &[T; ENTRIES],
    local: &[T],
    params: &[usize],
    translate: bool,
    np: usize,
    next: &mut Vec<T>,
) {
    let nl = params.len();
    next.resize(3 * np, T::zero());
    for a in 0..3 {
        let [r0, r1, r2] = [entries[3 * a], entries[3 * a + 1], entries[3 * a + 2]];
        let row = &mut next[a * np..(a + 1) * np];
        let (g0, rest) = v.g.split_at(np);
        let (g1, g2) = rest.split_at(np);
        for (((o, &x0), &x1), &x2) in row.iter_mut().zip(g0).zip(g1).zip(g2) {
            *o = r0.mul(x0).add(r1.mul(x1)).add(r2.mul(x2));
        }
        for (l, &j) in params.iter().enumerate() {
            let mut s = if translate {
                local[(9 + a) * nl + l]
            } else {
                T::zero()
            };
            for b in 0..3 {
                s = s.add(local[(3 * a + b) * nl + l].mul(v.x[b]));
            }
            row[j] = row[j].add(s);
        }
    }
    std::mem::swap(&mut v.g, next);
    v.x = std::array::from_fn(|a| {
        let t = if translate { entries[9 + a] } else { T::zero() };
        (0..3).fold(t, |acc, b| acc.add(entries[3 * a + b].mul(v.x[b])))
    });
}
