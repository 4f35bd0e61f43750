//! The order in which the gauge rule (`symbolic::identify`) considers the estimated
//! parameters: never the order of the spec's `params:` map (a mapping has none), but where
//! each parameter acts on the chain, from the reference frame out:
//!
//! 1. the joints from the base out, per joint `home, theta, d, offset, a, alpha, beta` and a
//!    URDF-native origin's `yaw, z, x, y, roll, pitch`: the arm's own nominals, which the
//!    maker's drawing makes trustworthy; so a rotation about the first axis is held by
//!    `home1`, a shift along it by `d1`, a scale by the first length that can carry one (and
//!    in `convention: urdf`, the first origin against the base, then each origin's `yaw` and
//!    `z` against the previous joint's turn about and shift along its axis);
//! 2. the tool;
//! 3. the base frame (`x, y, z, roll, pitch, yaw`): where a tracker or a fixture stands,
//!    often a guess;
//! 4. the constraints' own values (fixture coordinates) last: holding a Cartesian coordinate
//!    of an unknown socket at a guess cannot absorb a rotation about an axis (the gauge orbit
//!    is a circle, not a line), whereas an angle or a length along an axis moves exactly
//!    along the gauge direction it fixes. A plane by normal (`n·x = d`) lists its normal's
//!    entries by decreasing nominal magnitude, then its offset: an unknown normal's scale
//!    `(n, d) → (λn, λd)` is then held by its largest entry, which no plane near the nominal
//!    has at zero (holding a zero entry, or a zero offset, would make every tilted plane, or
//!    every plane off the origin, unreachable).
//!
//! A parameter used in several slots takes its first place; ties (and parameters in no slot)
//! are ordered by name.

use crate::spec::{Constraint, Slot, Spec};

/// The estimated parameters of `spec` (indices into [`Spec::estimated_params`]) in the order
/// the gauge rule walks them.
#[must_use]
pub fn gauge_priority(spec: &Spec) -> Vec<usize> {
    let estimated = spec.estimated_params();
    let mut rank: Vec<Option<(usize, usize, usize)>> = vec![None; estimated.len()];
    let mut visit = |name: Option<&str>, key: (usize, usize, usize)| {
        if let Some(j) = name.and_then(|n| estimated.iter().position(|p| p.name == n)) {
            if rank[j].is_none_or(|r| key < r) {
                rank[j] = Some(key);
            }
        }
    };
    if let Some(b) = &spec.base {
        for (s, slot) in [&b.x, &b.y, &b.z, &b.roll, &b.pitch, &b.yaw]
            .iter()
            .enumerate()
        {
            visit(slot.param(), (2, 0, s));
        }
    }
    for (i, joint) in spec.joints.iter().enumerate() {
        let slots = [
            &joint.home,
            &joint.theta,
            &joint.d,
            &joint.offset,
            &joint.a,
            &joint.alpha,
            &joint.beta,
        ];
        // A URDF-native origin's entries after them: first those a turn about, or a shift
        // along, the previous joint's axis moves alone (`yaw`, `z`: the left factor
        // `Rz(δ)·Tz(ε)` of `Tr(x, y, z)·Rz(yaw)·Ry(pitch)·Rx(roll)`), then `x`, `y` (a
        // prismatic joint's shift across its axis), then `roll`, `pitch`.
        let o = &joint.origin;
        let origin = [&o.yaw, &o.z, &o.x, &o.y, &o.roll, &o.pitch];
        for (s, slot) in slots.iter().chain(&origin).enumerate() {
            visit(slot.param(), (0, i, s));
        }
    }
    for (s, slot) in spec.tool.iter().enumerate() {
        visit(slot.param(), (1, 0, s));
    }
    for (c, constraint) in spec.constraints.iter().enumerate() {
        let slots = constraint.slots();
        let order = slot_order(spec, constraint);
        for (s, slot) in order.into_iter().map(|k| slots[k]).enumerate() {
            visit(slot.param(), (3, c, s));
        }
    }
    let mut order: Vec<usize> = (0..estimated.len()).collect();
    order.sort_by(|&x, &y| {
        let kx = rank[x].unwrap_or((4, 0, 0));
        let ky = rank[y].unwrap_or((4, 0, 0));
        kx.cmp(&ky)
            .then_with(|| estimated[x].name.cmp(&estimated[y].name))
    });
    order
}

/// The order in which the gauge rule sees a constraint's slots: as written, except a plane by
/// normal, whose normal entries come by decreasing nominal magnitude (ties as written), then
/// the offset.
fn slot_order(spec: &Spec, constraint: &Constraint) -> Vec<usize> {
    let slots = constraint.slots();
    let mut order: Vec<usize> = (0..slots.len()).collect();
    if let Constraint::PlaneNormal { normal, .. } = constraint {
        let size = |s: &Slot| -> f64 {
            match s {
                Slot::Const(e) => e.to_f64().abs(),
                Slot::Param(n) => spec.param(n).map_or(0.0, |p| p.nominal.to_f64().abs()),
            }
        };
        order[..3].sort_by(|&a, &b| size(&normal[b]).total_cmp(&size(&normal[a])));
    }
    order
}

#[cfg(test)]
mod tests {
    use super::gauge_priority;

    fn names(yaml: &str) -> Vec<String> {
        let spec = crate::spec::from_yaml_str(yaml, None).unwrap();
        let est = spec.estimated_params();
        gauge_priority(&spec)
            .into_iter()
            .map(|j| est[j].name.clone())
            .collect()
    }

    #[test]
    fn joints_then_tool_then_fixture_whatever_the_params_order() {
        let body = "name: t\ndim: 3\njoints:\n  - {type: revolute, a: a1, d: d1, home: h1}\n  \
                    - {type: revolute, a: a2, alpha: al2, home: h2}\ntool: [tx, 0, tz]\n\
                    constraint: {point: {p: [px, py, pz]}}\n";
        let params = [
            "px", "py", "pz", "tx", "tz", "a1", "d1", "h1", "a2", "al2", "h2",
        ];
        let want = [
            "h1", "d1", "a1", "h2", "a2", "al2", "tx", "tz", "px", "py", "pz",
        ];
        for order in [params.to_vec(), params.iter().rev().copied().collect()] {
            let list: String = order
                .iter()
                .map(|n| format!("  {n}: {{nominal: 0.1}}\n"))
                .collect();
            let got = names(&format!("{body}params:\n{list}"));
            assert_eq!(got, want, "params in the order {order:?}");
        }
    }

    #[test]
    fn a_plane_normal_is_held_by_its_largest_nominal_entry() {
        let yaml = "name: t\ndim: 3\njoints:\n  - {type: revolute, a: 0.3, d: 0.2}\n  \
                    - {type: revolute, a: 0.2, alpha: 0.5}\n\
                    constraint: {plane: {normal: [n1, n2, n3], offset: d}}\nparams:\n  \
                    d: {nominal: 0}\n  n1: {nominal: 0.1}\n  n2: {nominal: -0.2}\n  \
                    n3: {nominal: 1}\n";
        assert_eq!(names(yaml), ["n3", "n2", "n1", "d"]);
    }
}
