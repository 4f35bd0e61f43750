//! The data CSV of `shared/interface.md`, written from simulated or given poses.
//!
//! Takes the model, poses (or one pose's readings) and whether the file has `x, y(, z)` and
//! `constraint` columns; gives the header and rows, every value at full precision.

use std::io::Write;

use crate::data::Poses;
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;

/// Writes the data CSV header (see [`write_csv`]); `measured`: with `x, y(, z)` columns.
///
/// # Errors
/// The writer's I/O errors.
pub fn write_csv_header<W: Write>(
    w: &mut W,
    model: &dyn CalibModel,
    measured: bool,
    constraint_list: bool,
) -> std::io::Result<()> {
    let dim = model.dim();
    let mut header: Vec<String> = (1..=model.joint_count()).map(|i| format!("q{i}")).collect();
    if measured {
        header.extend(["x", "y", "z"][..dim].iter().map(|s| (*s).to_string()));
        let pose = (0..model.constraint_count())
            .any(|j| model.constraint_kind(j) == ConstraintKind::MeasuredPose);
        if pose {
            header.extend(["qw", "qx", "qy", "qz"].iter().map(|s| (*s).to_string()));
        }
    }
    if constraint_list {
        header.push("constraint".to_string());
    }
    writeln!(w, "{}", header.join(","))
}

/// Writes one data row (see [`write_csv`]): `measured` is `Some` (possibly empty) exactly
/// when the file has `x, y(, z)` columns; a measured pose's row (12 values: the tip, then
/// the rotation column-major) is written as `x, y, z, qw, qx, qy, qz`.
///
/// # Errors
/// The writer's I/O errors.
pub fn write_csv_row<W: Write>(
    w: &mut W,
    dim: usize,
    q: &[f64],
    measured: Option<&[f64]>,
    constraint: Option<usize>,
) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let mut line = String::new();
    for (i, v) in q.iter().enumerate() {
        if i > 0 {
            line.push(',');
        }
        let _ = write!(line, "{v:?}");
    }
    if let Some(tip) = measured {
        for i in 0..dim {
            line.push(',');
            if let Some(v) = tip.get(i) {
                let _ = write!(line, "{v:?}");
            }
        }
        if let Some(r) = tip.get(3..12).and_then(|r| <&[f64; 9]>::try_from(r).ok()) {
            for v in crate::model::rotation::quaternion_from_matrix(r) {
                let _ = write!(line, ",{v:?}");
            }
        }
    }
    if let Some(c) = constraint {
        let _ = write!(line, ",{c}");
    }
    writeln!(w, "{line}")
}

/// Writes poses as the data CSV of `shared/interface.md`: header `q1..qn`, then `x, y(, z)`
/// when any constraint is measured (blank on poses of other constraints), then `constraint`
/// when `constraint_list`; every value at full precision (shortest round-trip form).
///
/// # Errors
/// The writer's I/O errors.
pub fn write_csv<W: Write>(
    mut w: W,
    model: &dyn CalibModel,
    constraint_list: bool,
    poses: &Poses,
) -> std::io::Result<()> {
    write_csv_header(&mut w, model, poses.measured.is_some(), constraint_list)?;
    for l in 0..poses.len() {
        let measured = poses.measured.as_ref().map(|m| m.get(l).unwrap_or(&[]));
        let constraint = constraint_list.then(|| poses.constraint.at(l));
        write_csv_row(&mut w, model.dim(), &poses.q[l], measured, constraint)?;
    }
    Ok(())
}
