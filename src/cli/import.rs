//! `lincal import`: the serial chain between two links of a URDF as a spec (YAML on stdout),
//! with the URDF's record for `calibrate --write-urdf`.

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::ValueEnum;
use lincal::error::{Error, Result};
use lincal::spec;
use lincal::urdf;

use super::common::{field, write_text, MAX_URDF_BYTES};

/// The arguments of `import`.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// The URDF file.
    urdf: PathBuf,
    /// The chain's base link.
    #[arg(long)]
    base: String,
    /// The chain's tip link.
    #[arg(long)]
    tip: String,
    /// The tool point in the tip link's frame, `x,y,z` metres (default the link origin).
    #[arg(long, allow_hyphen_values = true)]
    tool: Option<String>,
    /// The table to write.
    #[arg(long, value_enum, default_value_t = ConventionArg::Dh)]
    convention: ConventionArg,
    /// The constraint block, with fresh unknown parameters (default `measured`, or
    /// `point` with `--points`).
    #[arg(long, value_enum)]
    constraint: Option<ConstraintArg>,
    /// With `point`: this many unknown pinned points (the sockets of one part), a
    /// `constraints:` list taking one data file per point, in order.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    points: u32,
    /// With `--points`: the known distances between consecutive points, metres: one value
    /// for every consecutive pair, or one per pair (`d01,d12,…`); written as `relations:`.
    #[arg(long, requires = "points")]
    distance: Option<String>,
}

/// `import`: the spec of the URDF's chain from `base` to `tip`, on `out`; the importer's
/// notes on stderr. The constraint defaults to `measured`, or `point` with `--points`.
pub fn run(out: &mut dyn Write, args: ImportArgs) -> Result<()> {
    let ImportArgs {
        urdf,
        base,
        tip,
        tool,
        convention,
        constraint,
        points,
        distance,
    } = args;
    let constraint = constraint.unwrap_or(if points > 1 {
        ConstraintArg::Point
    } else {
        ConstraintArg::Measured
    });
    let (path, points, distance) = (urdf.as_path(), points as usize, distance.as_deref());
    let tool = import_tool(tool.as_deref())?;
    let distances = import_distances(distance)?;
    if points < 2 && !distances.is_empty() {
        return Err(Error::input(
            field("--distance"),
            "distances need `--points 2` or more",
        ));
    }
    let text = lincal::error::read_input_file(path, "URDF file", MAX_URDF_BYTES)?;
    let recorded = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut command = import_command(path, &base, &tip, tool, convention, constraint);
    if points > 1 {
        command.push_str(&format!(" --points {points}"));
    }
    if let Some(d) = distance {
        command.push_str(&format!(" --distance {d}"));
    }
    let imported = urdf::import(
        &text,
        &path.display().to_string(),
        &urdf::ImportOptions {
            path: recorded.display().to_string(),
            base,
            tip,
            tool,
            points,
            distances,
            convention: match convention {
                ConventionArg::Dh => spec::Convention::Dh,
                ConventionArg::Mdh => spec::Convention::Mdh,
                ConventionArg::Urdf => spec::Convention::Urdf,
            },
            constraint: match constraint {
                ConstraintArg::Measured => urdf::ConstraintChoice::Measured,
                ConstraintArg::Point => urdf::ConstraintChoice::Point,
                ConstraintArg::Plane => urdf::ConstraintChoice::Plane,
                ConstraintArg::Sphere => urdf::ConstraintChoice::Sphere,
                ConstraintArg::Line => urdf::ConstraintChoice::Line,
                ConstraintArg::MeasuredPose => urdf::ConstraintChoice::MeasuredPose,
            },
            command,
        },
    )?;
    for note in &imported.notes {
        // A note quotes URDF names; no control character reaches the terminal.
        let note: String = note
            .chars()
            .map(|c| if c.is_control() { '?' } else { c })
            .collect();
        eprintln!("lincal: note: {note}");
    }
    write_text(out, &imported.yaml)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ConventionArg {
    /// Standard Denavit-Hartenberg.
    Dh,
    /// Modified Denavit-Hartenberg (Craig).
    Mdh,
    /// URDF-native: each joint origin's x, y, z, roll, pitch, yaw unknown, the redundant
    /// ones held by the exact gauge rule.
    Urdf,
}

/// Constraint block of `import`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ConstraintArg {
    /// Measured tip positions (data has x, y, z).
    Measured,
    /// An unknown pinned point.
    Point,
    /// An unknown plane.
    Plane,
    /// An unknown sphere.
    Sphere,
    /// An unknown 3-D line.
    Line,
    /// Measured tool frames, position and orientation (data has x, y, z and qw, qx, qy, qz
    /// or rx, ry, rz); the tool becomes a frame.
    #[value(name = "measured_pose")]
    MeasuredPose,
}

/// `import --distance d[,d…]`: finite numbers (the range is checked with the point count).
fn import_distances(distance: Option<&str>) -> Result<Vec<f64>> {
    let Some(d) = distance else {
        return Ok(Vec::new());
    };
    d.split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::input(
                        field("--distance"),
                        format!("`{}` is not a number (metres)", p.trim()),
                    )
                })
        })
        .collect()
}

/// `import --tool x,y,z`: three finite numbers (metres, at most 10⁹); zeros when not given.
fn import_tool(tool: Option<&str>) -> Result<[f64; 3]> {
    let Some(t) = tool else {
        return Ok([0.0; 3]);
    };
    let parts: Vec<&str> = t.split(',').map(str::trim).collect();
    let vals: Vec<f64> = parts
        .iter()
        .filter_map(|p| p.parse::<f64>().ok())
        .filter(|v| v.is_finite())
        .collect();
    match <[f64; 3]>::try_from(vals) {
        Ok(v) if parts.len() == 3 => Ok(v),
        _ => Err(Error::input(
            field("--tool"),
            format!("`{t}` is not three finite numbers `x,y,z` (metres)"),
        )),
    }
}

/// The `import` command line as the imported spec records it (every option spelled out;
/// `--tool` only when not zero).
fn import_command(
    path: &Path,
    base: &str,
    tip: &str,
    tool: [f64; 3],
    convention: ConventionArg,
    constraint: ConstraintArg,
) -> String {
    let name = |v: ConventionArg| format!("{v:?}").to_lowercase();
    format!(
        "lincal import {} --base {base} --tip {tip}{} --convention {} --constraint {}",
        path.display(),
        if tool.iter().any(|v| *v != 0.0) {
            format!(" --tool {},{},{}", tool[0], tool[1], tool[2])
        } else {
            String::new()
        },
        name(convention),
        constraint
            .to_possible_value()
            .map_or_else(String::new, |v| v.get_name().to_string())
    )
}
