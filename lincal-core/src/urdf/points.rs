//! `import --points n --distance d`: the constraint block of a part with `n` sockets (or
//! any `n` pinned points) at known distances, so that the socket workflow needs no YAML
//! editing: `n` unknown points, all at the tip's nominal at zero readings (the fit starts
//! each from its own data, [`crate::fit::start`]), and `relations:` for the distances
//! between consecutive points.

use super::num;
use crate::error::{Error, Result};

/// `--points n` (n ≥ 2): a `constraints:` list of `n` unknown pinned points, all at the tip
/// at zero readings (the fit starts each from its own data), and the known distances between
/// consecutive points as `relations:`.
/// `point` says whether the constraint asked for is `point` (`--constraint`), `d` are the
/// distances of `--distance`.
pub(super) fn points_block(
    n: usize,
    d: &[f64],
    point: bool,
    tip: [f64; 3],
) -> Result<(String, Vec<(String, String)>)> {
    let bad = |field: &str, msg: String| {
        Err(Error::input(
            crate::error::Location {
                field: Some(field.into()),
                ..Default::default()
            },
            msg,
        ))
    };
    if !point {
        return bad(
            "--points",
            "several points need `--constraint point` (or no `--constraint`)".into(),
        );
    }
    if n > 1000 {
        return bad("--points", format!("{n} points: at most 1000"));
    }
    if !(d.is_empty() || d.len() == 1 || d.len() == n - 1) {
        return bad(
            "--distance",
            format!(
                "{} distances for {n} points: give one (every consecutive pair) or {}",
                d.len(),
                n - 1
            ),
        );
    }
    if let Some(v) = d
        .iter()
        .find(|v| !(v.is_finite() && **v > 0.0 && **v <= 1e3))
    {
        return bad(
            "--distance",
            format!("{v} is not a distance in (0, 1000] metres"),
        );
    }
    let mut y = String::from("constraints:\n");
    let mut params = Vec::new();
    for i in 0..n {
        y.push_str(&format!("  - point: {{p: [p{i}x, p{i}y, p{i}z]}}\n"));
        for (k, v) in ["x", "y", "z"].iter().zip(tip) {
            params.push((format!("p{i}{k}"), num(v)));
        }
    }
    if !d.is_empty() {
        y.push_str("relations:\n");
        for i in 0..n - 1 {
            let v = if d.len() == 1 { d[0] } else { d[i] };
            // Exactly as given: `num` writes values below 1e-15 as 0 (rounding noise of a
            // URDF's geometry), which a distance is not.
            y.push_str(&format!(
                "  - {{distance: [{i}, {}], value: {}}}\n",
                i + 1,
                super::num_exact(v)
            ));
        }
    }
    Ok((y, params))
}
