//! The order in which the gauge rule (`symbolic::identify`) considers the estimated
//! parameters: never the order of the spec's `params:` map (a mapping has none), but where
//! each parameter acts on the chain, from the reference frame out:
//!
//! 1. the joints from the base out, per joint `home, theta, d, offset, a, alpha`: the arm's
//!    own nominals, which the maker's drawing makes trustworthy; so a rotation about the first
//!    axis is held by `home1`, a shift along it by `d1`, a scale by the first length that
//!    can carry one;
//! 2. the tool;
//! 3. the base frame (`x, y, z, roll, pitch, yaw`): where a tracker or a fixture stands,
//!    often a guess;
//! 4. the constraints' own values (fixture coordinates) last: holding a Cartesian coordinate
//!    of an unknown socket at a guess cannot absorb a rotation about an axis (the gauge orbit
//!    is a circle, not a line), whereas an angle or a length along an axis moves exactly
//!    along the gauge direction it fixes.
//!
//! A parameter used in several slots takes its first place; ties (and parameters in no slot)
//! are ordered by name.

use crate::spec::Spec;

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
        ];
        for (s, slot) in slots.iter().enumerate() {
            visit(slot.param(), (0, i, s));
        }
    }
    for (s, slot) in spec.tool.iter().enumerate() {
        visit(slot.param(), (1, 0, s));
    }
    for (c, constraint) in spec.constraints.iter().enumerate() {
        for (s, slot) in constraint.slots().into_iter().enumerate() {
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
}
