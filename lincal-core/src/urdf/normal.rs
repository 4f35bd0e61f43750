//! The common normal of two joint axes, from which the DH frames are built (see
//! [`super::import`]'s module docs).

use super::frame::{axpy, cross, dot, norm, unit};

/// Axes whose directions' cross product is at most this long are parallel.
pub(super) const PARALLEL: f64 = 1e-14;
/// Feet closer than this are one point (the axes meet).
const SAME_POINT: f64 = 1e-13;
/// A normal whose feet lie farther than this (metres) along the axes is refused.
const FAR: f64 = 1e3;

/// The common normal of two axes: its foot on the first, its direction and length (through
/// the first line's point when the axes are parallel: the import gives such axes Hayati's
/// row, [`super::axes`], and never asks).
pub(super) struct Normal {
    /// The foot on the first axis.
    pub(super) f: [f64; 3],
    /// The unit direction from it.
    pub(super) x: [f64; 3],
    /// The length.
    pub(super) a: f64,
}

/// `a − b`.
pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The signed angle turning `from` into `to` about the unit `axis` (both ⊥ `axis`).
pub(super) fn angle_about(from: [f64; 3], to: [f64; 3], axis: [f64; 3]) -> f64 {
    dot(cross(from, to), axis).atan2(dot(from, to))
}

/// The common normal from line `(o, z)` to line `(p, w)` (see the module docs); `prefer`
/// picks the sign when the lines meet or coincide. `None` when nearly parallel with a far
/// normal (the distance is returned).
pub(super) fn common_normal(
    o: [f64; 3],
    z: [f64; 3],
    p: [f64; 3],
    w: [f64; 3],
    prefer: [f64; 3],
) -> std::result::Result<Normal, f64> {
    let c = cross(z, w);
    let cn = norm(c);
    let r = sub(p, o);
    let (f, g, parallel) = if cn <= PARALLEL {
        (o, axpy(p, dot(sub(o, p), w), w), true)
    } else {
        let t = dot(cross(r, w), c) / (cn * cn);
        let s = dot(cross(r, z), c) / (cn * cn);
        if t.abs() > FAR || s.abs() > FAR {
            return Err(t.abs().max(s.abs()));
        }
        (axpy(o, t, z), axpy(p, s, w), false)
    };
    let d = sub(g, f);
    let a = norm(d);
    if a > SAME_POINT {
        return Ok(Normal { f, x: unit(d), a });
    }
    let x = if parallel {
        prefer
    } else {
        let cu = unit(c);
        if dot(cu, prefer) < 0.0 {
            [-cu[0], -cu[1], -cu[2]]
        } else {
            cu
        }
    };
    Ok(Normal { f, x, a: 0.0 })
}
