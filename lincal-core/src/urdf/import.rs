//! URDF chain → spec: the Denavit-Hartenberg table of the chain's joint axes.
//!
//! # Geometry
//! At zero readings every moving joint `i` is a line in the base link's frame: the point
//! `p_i` (origin of the URDF joint frame `U_i`) and the unit direction `u_i = R(U_i)·axis_i`.
//! The z axis of the frame each joint moves in is `+u_i`, never `−u_i`: the reading then
//! enters as `θ_i = q_i − home_i` (or `d_i = q_i + offset_i`) with a plus sign, as the spec
//! requires, whatever sign the URDF axis has. The frames are built from the **common
//! normal** of consecutive axes: for lines `(o, z)` and `(p, w)` with `c = z × w ≠ 0`, the
//! closest points are `f = o + t·z`, `g = p + s·w` with
//! `t = ((p − o) × w)·c / |c|²`, `s = ((p − o) × z)·c / |c|²`; the normal runs along
//! `x = (g − f)/|g − f|` (along `±c/|c|` when the lines meet, the sign nearest the previous
//! x axis), and has length `a = |g − f|`.
//!
//! **Standard DH** (`A_i = Rz(θ_i)Tz(d_i)Tx(a_i)Rx(α_i)`): frame `i − 1` has `z = u_i`;
//! frame `i` sits at the foot `g` on axis `i + 1` with `x_i` along the normal, so
//! `d_i = (f − o_{i−1})·u_i`, `a_i = |g − f|`, the angle `θ_i⁰` turns `x_{i−1}` into `x_i`
//! about `u_i` and `α_i` turns `u_i` into `u_{i+1}` about `x_i`. A revolute joint gets
//! `home_i = −θ_i⁰` (so `θ_i = q_i − home_i` is `θ_i⁰` at `q_i = 0`); a prismatic one gets
//! `theta_i = θ_i⁰`, `offset_i = d_i`.
//! **Modified DH** (`A_i = Rx(α_{i−1})Tx(a_{i−1})Rz(θ_i)Tz(d_i)`): frame `i` lies on axis
//! `i` at the foot `f` of the normal to axis `i + 1`; row `i + 1` holds that normal's twist
//! and length, row `i` the offset `d_i` along `u_i` from the previous normal's foot and the
//! angle `θ_i⁰` between the two normals.
//!
//! **Parallel and nearly parallel axes** (the sine of the angle at most
//! [`NEAR_PARALLEL`](super::NEAR_PARALLEL), 0.1) have no unique normal, or one that runs off as
//! the axes become parallel and turns with the smallest tilt: no DH table takes a tilt of such
//! a pair about the other perpendicular (the normal of the tilted axes runs off to infinity,
//! and `d` with it), and real arms have one. The row of the pair is then Hayati's (built in
//! `urdf/axes.rs`): its stand-in for the normal is taken through the previous origin (the
//! offset along the pair `d_i = 0`, redundant with the next row's, is left out of a revolute
//! row), and the tilt is `beta` (`…·Rx(α)·Ry(β)` in DH, `Rx(α)·Ry(β)·…` in modified DH) with
//! the actual tilt as its nominal: 0 for exactly parallel axes. After a prismatic joint the
//! same row is written; its `theta` is then written as its value, not a parameter: the
//! prismatic axis has no place, so `theta` would be a fourth angle for the three turns that
//! `alpha`, `beta` and the next joint's angle about its own axis already give. The table is
//! then complete at the URDF's own geometry (the rank of the measurement's Jacobian at the
//! nominals is the known maximum, `4R + 2P + 6` for a measured pose, 3 fewer for a position;
//! `tests/numeric/completeness.rs`) and adds no redundancy of its own. A common normal more
//! than 1 km away (axes more than about 100 m apart) is refused, naming the joints. Axes within
//! [`SNAP_PARALLEL`] (10⁻⁴ rad) of parallel, as a URDF that writes π as `3.1416` has, are first
//! made exactly parallel, with a note naming the joints; the check below then allows the tip
//! gap that snapping makes.
//!
//! **Base and tool.** The base transform `B` (all six entries named) takes the base link to
//! frame 0: z along `u_1`, origin at the foot of the base link's origin on axis 1, x the base
//! x axis made perpendicular to `u_1`. Fixed joints are folded in: before the first moving
//! joint into `B`, between moving joints into the frames, after the last one into the
//! tool. The last row has no next axis; its frame is frame `n − 1` turned by the joint, and
//! the tool vector (named) is the tip point in it, which is exactly the freedom the last
//! link has (`Tz(d)Tx(a)Rx(α)·t` reaches nothing that `t` alone does not), so those entries
//! are written as `0`. In MDH the first row's `α`, `a` are 0 for the same reason (the base
//! holds them) and so is the last `d` (the tool holds it).
//!
//! The result is checked before it is returned: the written spec is loaded again and its
//! tip compared with the URDF's at random readings (agreement to 10⁻¹² m is typical; more
//! than 10⁻⁹ m is an internal error).

use super::axes::{Axes, Line, Rows};
use super::chain::{ElementKind, UrdfChain};
use super::frame::{axpy, cross, dot, norm, unit, Iso};
use super::native::native_rows;
use super::normal::{sub, PARALLEL};
use super::num;
use super::record::{yaml_string, UrdfRecord};
use crate::error::{Error, Location, Result};
use crate::spec::{Convention, RowForm};

/// The constraint block an imported spec gets (with fresh unknown parameters).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConstraintChoice {
    /// `measured`: the tip is measured (data has `x, y, z`).
    Measured,
    /// `point` with unknown `px, py, pz`.
    Point,
    /// `plane` with unknown `b1, b2, b3`.
    Plane,
    /// `sphere` with unknown centre `cx, cy, cz` and radius `r`.
    Sphere,
    /// `line` (two planes) with unknown `b11 … b23`.
    Line,
    /// `measured_pose`: the tip link's frame (moved by the tool point) is measured; the
    /// spec's tool is then a frame `{x, y, z, roll, pitch, yaw}`.
    MeasuredPose,
}

/// What `lincal import` was asked.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportOptions {
    /// The URDF path as it goes into the spec's `urdf:` record.
    pub path: String,
    /// The base link.
    pub base: String,
    /// The tip link.
    pub tip: String,
    /// The tool point in the tip link's frame.
    pub tool: [f64; 3],
    /// The table to write.
    pub convention: Convention,
    /// The constraint block.
    pub constraint: ConstraintChoice,
    /// With [`ConstraintChoice::Point`]: how many pinned points (sockets of one part). One
    /// writes `constraint: point`; `n ≥ 2` writes a `constraints:` list of `n` unknown points
    /// `p{i}x, p{i}y, p{i}z`, all with the same nominal (the fit starts them from the data),
    /// one data file per point, in order.
    pub points: usize,
    /// With `points ≥ 2`: the known distances between consecutive points (metres), written as
    /// `relations: [{distance: [i, i+1], value: d}]`; one value for every consecutive pair, or
    /// `points − 1` values in order; empty for none.
    pub distances: Vec<f64>,
    /// The command line, for the spec's header comment.
    pub command: String,
}

/// An imported spec.
#[derive(Clone, Debug, PartialEq)]
pub struct Imported {
    /// The spec, YAML text.
    pub yaml: String,
    /// Notes the user should read (parallel axes, folded fixed joints), also in the YAML as
    /// comments.
    pub notes: Vec<String>,
    /// The largest tip difference from the URDF found by the check (metres).
    pub check: f64,
}

/// Consecutive joint axes within this angle (radians) of parallel are made exactly parallel
/// on import: vendors write π as `3.1416`, which tilts an axis by ~10⁻⁵ rad. Axis `i + 1`'s
/// direction becomes `±u_i` (the sign of `u_i·u_{i+1}`), its point stays; the tip then moves
/// by at most about `2·δ·r` (`δ` the angle, `r` the reach beyond the joint), and the spec's
/// header notes the joints and the angle.
pub const SNAP_PARALLEL: f64 = 1e-4;

/// An angle: an exact multiple of π/2 when within 10⁻¹⁴ of one, else the number.
fn angle(v: f64) -> String {
    let k = (v / std::f64::consts::FRAC_PI_2).round();
    if (v - k * std::f64::consts::FRAC_PI_2).abs() < 1e-14 && k.abs() <= 4.0 {
        return match k as i64 {
            0 => "0".into(),
            1 => "pi/2".into(),
            -1 => "-pi/2".into(),
            2 => "pi".into(),
            -2 => "-pi".into(),
            3 => "3*pi/2".into(),
            -3 => "-3*pi/2".into(),
            4 => "2*pi".into(),
            _ => "-2*pi".into(),
        };
    }
    num(v)
}

/// An identifier made from the robot's name.
fn ident(s: &str) -> String {
    let mut out: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, 'r');
    }
    out
}

/// One row of the table: the slot texts (`None`: left out, i.e. 0) and the parameters.
struct TableRow {
    prismatic: bool,
    slots: Vec<(&'static str, String)>,
    limits: Option<[f64; 2]>,
    comment: String,
}

/// Converts the chain between `opts.base` and `opts.tip` of the URDF `text` (`file` names
/// it in errors) to a spec.
///
/// # Errors
/// The chain's errors ([`UrdfChain::from_str`]); an input error naming both joints when the
/// common normal of two consecutive axes lies more than 1 km away; an internal error if the
/// written spec does not reproduce the URDF (a bug).
pub fn import(text: &str, file: &str, opts: &ImportOptions) -> Result<Imported> {
    let robot = super::read::read(text, file)?;
    let chain = UrdfChain::from_robot(&robot, file, &opts.base, &opts.tip)?;
    check_tool(opts.tool)?;
    let line_of = |name: &str| robot.joints.iter().find(|j| j.name == name).map(|j| j.line);
    let robot_name = robot.name.clone();

    let folded = chain
        .elements
        .iter()
        .filter(|e| e.kind == ElementKind::Fixed)
        .map(|e| e.name.clone())
        .collect::<Vec<_>>();
    let mut notes = chain.dropped_limits(&robot);
    let Table {
        rows,
        mut params,
        base,
        last,
        tip,
        names,
        slack,
    } = match opts.convention {
        Convention::Urdf => native_table(&chain, opts.tool, &line_of, &mut notes),
        dh => dh_table(&chain, opts.tool, dh, file, &line_of, &mut notes)?,
    };
    base_and_tool(&mut params, &base, last.inverse().apply(tip));
    let pose = opts.constraint == ConstraintChoice::MeasuredPose;
    params.extend(tool_angles(pose, &chain, &last, names.len()));
    let (constraint, cparams) = if opts.points > 1 {
        super::points::points_block(
            opts.points,
            &opts.distances,
            opts.constraint == ConstraintChoice::Point,
            tip,
        )?
    } else {
        constraint_block(opts.constraint, tip)?
    };

    let mut y = header_comments(opts, &chain, file, &names, &folded, &notes);
    y.push_str(&format!("name: {}\n", ident(&robot_name)));
    y.push_str(&format!(
        "description: {}\n",
        yaml_string(&format!(
            "{} from {} to {} (URDF {})",
            robot_name, chain.base, chain.tip, file
        ))
    ));
    push_body(
        &mut y,
        opts.convention,
        &rows,
        pose,
        params.iter().chain(cparams.iter()),
    );
    y.push_str(&constraint);
    let record = UrdfRecord {
        path: opts.path.clone(),
        base: chain.base.clone(),
        tip: chain.tip.clone(),
        tool: opts.tool,
        joints: names,
    };
    y.push_str(&record.to_yaml());

    let check = super::numeric::check_import(&y, &chain, opts.tool, slack)?;
    // A chain too long for the exact engine imports (and `predict` takes it), but say so now
    // rather than at the first `basis`, `simulate` or `calibrate`.
    if let Ok(spec) = crate::spec::from_yaml_str(&y, None) {
        if let Err(e) = crate::symbolic::slots::slot_polys(&spec) {
            notes.push(format!("{e}"));
        }
    }
    Ok(Imported {
        yaml: y,
        notes,
        check,
    })
}

/// The base's six nominals and the tool point's three (in the last joint's frame).
fn base_and_tool(params: &mut Vec<(String, String)>, base: &Iso, tool: [f64; 3]) {
    for (k, v) in ["x", "y", "z"].iter().zip(base.t) {
        params.push((format!("base_{k}"), num(v)));
    }
    for (k, v) in ["roll", "pitch", "yaw"].iter().zip(base.rpy()) {
        params.push((format!("base_{k}"), angle(v)));
    }
    for (k, v) in ["x", "y", "z"].iter().zip(tool) {
        params.push((format!("tool_{k}"), num(v)));
    }
}

/// What a table gives the spec: its rows with their parameters, the base frame's nominal,
/// the last joint's frame and the tip (base link frame, zero readings), the moving joints'
/// names and how far the table may sit from the URDF (parallel axes snapped).
struct Table {
    rows: Vec<TableRow>,
    params: Vec<(String, String)>,
    base: Iso,
    last: Iso,
    tip: [f64; 3],
    names: Vec<String>,
    slack: f64,
}

/// The DH (or modified DH) table of the chain's axes (module docs).
fn dh_table(
    chain: &UrdfChain,
    tool: [f64; 3],
    convention: Convention,
    file: &str,
    line_of: &dyn Fn(&str) -> Option<usize>,
    notes: &mut Vec<String>,
) -> Result<Table> {
    let (mut lines, tip) = joint_lines(chain, tool);
    let slack = snap_parallel(&mut lines, tip, notes);
    let (o0, x0) = frame0(&lines);
    let base = Iso::from_axes(x0, cross(lines[0].u, x0), lines[0].u, o0);
    let axes = Axes {
        lines: &lines,
        file,
        line_of,
    };
    let (vals, last) = match convention {
        Convention::Mdh => axes.mdh_values(o0, x0, notes)?,
        _ => axes.dh_values(o0, x0, notes)?,
    };
    let (rows, params) = table(convention.row(), &lines, &vals, line_of);
    let names = joint_names(&lines, notes);
    Ok(Table {
        rows,
        params,
        base,
        last,
        tip,
        names,
        slack,
    })
}

/// The URDF-native table ([`super::native`]): each joint's origin, six unknowns.
fn native_table(
    chain: &UrdfChain,
    tool: [f64; 3],
    line_of: &dyn Fn(&str) -> Option<usize>,
    notes: &mut Vec<String>,
) -> Table {
    let (native, last, tip) = native_rows(chain, tool);
    let mut params = Vec::new();
    let mut rows = Vec::with_capacity(native.len());
    let mut turned = Vec::new();
    for (i, r) in native.iter().enumerate() {
        let k = i + 1;
        let mut slots = Vec::with_capacity(6);
        let values = r.xyz.map(num).into_iter().chain(r.rpy.map(angle));
        for (slot, v) in ["x", "y", "z", "roll", "pitch", "yaw"]
            .into_iter()
            .zip(values)
        {
            let p = format!("{slot}{k}");
            params.push((p.clone(), v));
            slots.push((slot, p));
        }
        if r.turned {
            turned.push(r.name.clone());
        }
        rows.push(TableRow {
            prismatic: r.prismatic,
            slots,
            limits: r.limits,
            comment: format!(
                "{} (line {})",
                r.name,
                line_of(&r.name).map_or("?".to_string(), |x| x.to_string())
            ),
        });
    }
    if !turned.is_empty() {
        notes.push(format!(
            "the frames of {} are their URDF joint frames turned so that the joint moves about \
             (or along) z, its origin's pitch away from ±90°; `--write-urdf` writes the URDF's \
             own frames back",
            turned.join(", ")
        ));
    }
    let names: Vec<String> = native.iter().map(|r| r.name.clone()).collect();
    notes.extend(position_name_clashes(&names));
    Table {
        rows,
        params,
        base: Iso::IDENTITY,
        last,
        tip,
        names,
        slack: 0.0,
    }
}

/// A tool frame's angles (`tool_roll`, `tool_pitch`, `tool_yaw`) when the `pose` is measured:
/// the tip link's axes in the last DH frame `last`, at zero readings (as the table is).
fn tool_angles(pose: bool, chain: &UrdfChain, last: &Iso, joints: usize) -> Vec<(String, String)> {
    if !pose {
        return Vec::new();
    }
    let frame = last.inverse().mul(&chain.tip_frame(&vec![0.0; joints]));
    ["roll", "pitch", "yaw"]
        .iter()
        .zip(frame.rpy())
        .map(|(k, v)| (format!("tool_{k}"), angle(v)))
        .collect()
}

/// The tool point is finite and within [`super::chain::MAX_LENGTH`] of the tip link (an
/// input error naming `--tool` otherwise).
fn check_tool(tool: [f64; 3]) -> Result<()> {
    if tool
        .iter()
        .all(|v| v.is_finite() && v.abs() <= super::chain::MAX_LENGTH)
    {
        return Ok(());
    }
    Err(Error::input(
        Location {
            field: Some("--tool".to_string()),
            ..Location::default()
        },
        format!(
            "the tool point {tool:?} is beyond {:e} m of the tip link: no tool is that long \
             (a unit slip, millimetres for metres?)",
            super::chain::MAX_LENGTH
        ),
    ))
}

/// The moving joints' lines at zero readings (base frame) and the tip point (`tool` in the
/// tip link's frame).
fn joint_lines(chain: &UrdfChain, tool: [f64; 3]) -> (Vec<Line>, [f64; 3]) {
    let mut t = Iso::IDENTITY;
    let mut lines: Vec<Line> = Vec::new();
    for e in &chain.elements {
        t = t.mul(&e.origin);
        match e.kind {
            ElementKind::Fixed => {}
            k => lines.push(Line {
                name: e.name.clone(),
                p: t.t,
                u: unit(t.rotate(e.axis)),
                prismatic: k == ElementKind::Prismatic,
                limits: e.limits,
            }),
        }
    }
    (lines, t.apply(tool))
}

/// Makes consecutive axes within [`SNAP_PARALLEL`] of parallel exactly parallel (axis
/// `i + 1` becomes `±u_i`), with a note naming the joints; returns how far that may move the
/// tip at the check's readings: `Σ 4·δ·(R + 1 m)` over the snapped axes, `δ` the angle and
/// `R` the distance from the chain's first joint to the farthest of the later joints and the
/// tip (the 1 m covers a prismatic joint's travel).
fn snap_parallel(lines: &mut [Line], tip: [f64; 3], notes: &mut Vec<String>) -> f64 {
    let mut slack = 0.0;
    for i in 1..lines.len() {
        let (u0, u) = (lines[i - 1].u, lines[i].u);
        let delta = norm(cross(u0, u)).min(1.0).asin();
        if delta <= PARALLEL || delta > SNAP_PARALLEL {
            continue;
        }
        let sign = if dot(u0, u) < 0.0 { -1.0 } else { 1.0 };
        lines[i].u = [sign * u0[0], sign * u0[1], sign * u0[2]];
        let p = lines[0].p;
        let reach = lines
            .iter()
            .map(|l| norm(sub(l.p, p)))
            .chain(std::iter::once(norm(sub(tip, p))))
            .fold(0.0, f64::max);
        slack += 4.0 * delta * (reach + 1.0);
        notes.push(format!(
            "the axes of joints `{}` and `{}` are {delta:.1e} rad from parallel (within the \
             import's {SNAP_PARALLEL:.0e} rad, as a rounded π gives): `{}`'s axis was made \
             exactly parallel, so the spec's tips differ from the URDF's by up to about \
             {delta:.0e} × the reach",
            lines[i - 1].name,
            lines[i].name,
            lines[i].name
        ));
    }
    slack
}

/// The chain's joint names, base first, with a note for each that another column's usual
/// name would shadow ([`position_name_clashes`]).
fn joint_names(lines: &[Line], notes: &mut Vec<String>) -> Vec<String> {
    let names: Vec<String> = lines.iter().map(|l| l.name.clone()).collect();
    notes.extend(position_name_clashes(&names));
    names
}

/// A note for each joint whose URDF name is another position's usual column name (joint 1
/// named `q2`): a data column headed by that name is read by its position, so a joint-state
/// log headed by URDF names would give that joint another's readings.
fn position_name_clashes(names: &[String]) -> Vec<String> {
    names
        .iter()
        .enumerate()
        .filter_map(|(i, name)| {
            let k: usize = name.strip_prefix('q')?.parse().ok()?;
            // `q7` on a 3-joint arm is no column's name: an alias as any other.
            (k >= 1 && k <= names.len() && name == &format!("q{k}") && k != i + 1).then(|| {
                format!(
                    "joint {} of the chain is named `{name}` in the URDF: a data column headed \
                     `{name}` is read as joint {k} (the usual name by position wins); head \
                     joint {}'s column `q{}`",
                    i + 1,
                    i + 1,
                    i + 1
                )
            })
        })
        .collect()
}

/// Frame 0's origin and x axis: z along axis 1, at the foot of the base origin, x the base
/// x made ⊥ (the base y when the base x is along the axis).
fn frame0(lines: &[Line]) -> ([f64; 3], [f64; 3]) {
    let u1 = lines[0].u;
    let o0 = axpy(lines[0].p, -dot(lines[0].p, u1), u1);
    let mut x0 = axpy([1.0, 0.0, 0.0], -u1[0], u1);
    if norm(x0) < 1e-6 {
        x0 = axpy([0.0, 1.0, 0.0], -u1[1], u1);
    }
    (o0, unit(x0))
}

/// The table rows and their parameters' nominals, with the exactly redundant entries left
/// at 0 (see the module docs).
fn table(
    convention: RowForm,
    lines: &[Line],
    vals: &Rows,
    line_of: &dyn Fn(&str) -> Option<usize>,
) -> (Vec<TableRow>, Vec<(String, String)>) {
    let n = lines.len();
    let mut params: Vec<(String, String)> = Vec::new();
    let mut rows = Vec::with_capacity(n);
    // Axes `i` and `i + 1` parallel or nearly so: the pair gets Hayati's row (module docs).
    let hayati = |i: usize| vals.hayati.get(i).copied().unwrap_or(false);
    for (i, l) in lines.iter().enumerate() {
        let k = i + 1;
        let v = vals.vals[i];
        let (a, al, d, th) = (v.a, v.alpha, v.d, v.theta);
        let is_last = i + 1 == n;
        // The row holding the pair's normal takes the tilt, right after its twist; a revolute
        // joint's offset along the pair (0 by construction, redundant) is left out.
        let (tilt, d_fixed) = match convention {
            RowForm::Dh => (hayati(i), hayati(i)),
            RowForm::Mdh => (i > 0 && hayati(i - 1), hayati(i)),
        };
        let mut slots: Vec<(&'static str, String)> = Vec::new();
        let name = |slot: &'static str, value: String, params: &mut Vec<(String, String)>| {
            let p = format!("{slot}{k}");
            params.push((p.clone(), value));
            (slot, p)
        };
        let (with_link, with_offset) = match convention {
            RowForm::Dh => (!is_last, !is_last),
            RowForm::Mdh => (i > 0, !is_last),
        };
        if with_link {
            slots.push(name("a", num(a), &mut params));
            slots.push(name("alpha", angle(al), &mut params));
            if tilt {
                slots.push(name("beta", angle(v.beta), &mut params));
            }
        }
        if l.prismatic {
            // With Hayati's row after it, a prismatic joint's `theta` is a fourth angle for
            // three turns (`alpha`, `beta` and the next joint's angle about its own axis):
            // written as its value, not a parameter (module docs).
            if !is_last && hayati(i) {
                slots.push(("theta", angle(th)));
            } else if !is_last {
                slots.push(name("theta", angle(th), &mut params));
            }
            if with_offset {
                slots.push(name("offset", num(d), &mut params));
            }
        } else {
            if with_offset && !d_fixed {
                slots.push(name("d", num(d), &mut params));
            }
            slots.push(name("home", angle(-th), &mut params));
        }
        rows.push(TableRow {
            prismatic: l.prismatic,
            slots,
            limits: l.limits,
            comment: format!(
                "{} (line {})",
                l.name,
                line_of(&l.name).map_or("?".to_string(), |x| x.to_string())
            ),
        });
    }
    (rows, params)
}

/// The spec's opening comments: where it comes from, the reading convention, which data
/// column is which URDF joint (`joints`, the moving joints' names), the folded fixed joints
/// and the notes.
fn header_comments(
    opts: &ImportOptions,
    chain: &UrdfChain,
    file: &str,
    joints: &[String],
    folded: &[String],
    notes: &[String],
) -> String {
    let mut y = String::new();
    y.push_str(&format!("# Written by `{}`.\n", opts.command));
    let table = match opts.convention {
        Convention::Dh => "a standard Denavit-Hartenberg table",
        Convention::Mdh => "a modified Denavit-Hartenberg table",
        Convention::Urdf => "URDF-native rows (each joint's origin x, y, z, roll, pitch, yaw)",
    };
    y.push_str(&format!(
        "# The serial chain {} -> {} of {} ({} moving joints), as {table} whose nominals \
         reproduce the URDF.\n",
        chain.base,
        chain.tip,
        file,
        joints.len(),
    ));
    y.push_str(if opts.convention == Convention::Urdf {
        "# Readings: each joint turns by q_i about (or slides by q_i along) the z axis of its \
         origin, q_i the URDF joint value; the gauge rule holds the redundant origin entries.\n"
    } else {
        "# Readings: theta_i = q_i - home_i (revolute), d_i = q_i + offset_i (prismatic), q_i the \
         URDF joint value.\n"
    });
    let columns: Vec<String> = joints
        .iter()
        .enumerate()
        .map(|(i, j)| format!("q{} (= {j})", i + 1))
        .collect();
    y.push_str(&format!(
        "# Data columns: {} (a column may be headed by either name).\n",
        columns.join(", ")
    ));
    if opts.points > 1 {
        let files = if opts.points <= 3 {
            (0..opts.points)
                .map(|i| format!("point_{i}.csv"))
                .collect::<Vec<_>>()
                .join(" ")
        } else {
            format!("point_0.csv … point_{}.csv", opts.points - 1)
        };
        y.push_str(&format!(
            "# Data: one file per point, in order: `lincal calibrate SPEC {files}` (the points \
             start from the data, not from these nominals).\n"
        ));
    }
    if !folded.is_empty() {
        y.push_str(&format!(
            "# Fixed joints folded into base, frames and tool: {}.\n",
            folded.join(", ")
        ));
    }
    y.push_str(if opts.convention == Convention::Urdf {
        "# The tool vector is the tip point in the last joint's frame (it carries the last link).\n"
    } else {
        "# The tool vector is the tip point in the last joint's frame (it carries the last link); \
         entries that only repeat the base or the tool are 0.\n"
    });
    for note in notes {
        y.push_str(&format!("# Note: {note}.\n"));
    }
    y
}

/// The spec's `dim`, `convention`, `joints`, `tool`, `base` and `params` entries.
fn push_body<'p>(
    y: &mut String,
    convention: Convention,
    rows: &[TableRow],
    tool_frame: bool,
    params: impl Iterator<Item = &'p (String, String)>,
) {
    let conv = convention.name();
    y.push_str(&format!("dim: 3\nconvention: {conv}\njoints:\n"));
    for r in rows {
        let mut parts = vec![format!(
            "type: {}",
            if r.prismatic { "prismatic" } else { "revolute" }
        )];
        parts.extend(r.slots.iter().map(|(s, p)| format!("{s}: {p}")));
        if let Some([lo, hi]) = r.limits {
            parts.push(format!("limits: [{}, {}]", num(lo), num(hi)));
        }
        y.push_str(&format!("  - {{{}}}   # {}\n", parts.join(", "), r.comment));
    }
    if tool_frame {
        y.push_str(
            "tool: {x: tool_x, y: tool_y, z: tool_z, roll: tool_roll, pitch: tool_pitch, yaw: \
             tool_yaw}\n",
        );
    } else {
        y.push_str("tool: [tool_x, tool_y, tool_z]\n");
    }
    y.push_str(
        "base: {x: base_x, y: base_y, z: base_z, roll: base_roll, pitch: base_pitch, yaw: \
         base_yaw}\n",
    );
    y.push_str("params:\n");
    for (p, v) in params {
        y.push_str(&format!("  {p}: {{nominal: {v}}}\n"));
    }
}

/// The constraint block and its parameters' nominals (started at the tip at zero readings).
fn constraint_block(
    choice: ConstraintChoice,
    tip: [f64; 3],
) -> Result<(String, Vec<(String, String)>)> {
    let p2 = dot(tip, tip);
    let plane = |w: [f64; 3]| [-w[0] / p2, -w[1] / p2, -w[2] / p2];
    let need_offset = || {
        if p2 < 1e-12 {
            Err(Error::input(
                crate::error::Location {
                    field: Some("--constraint".into()),
                    ..Default::default()
                },
                "the tip is at the base origin at zero readings, so no nominal plane `b·x + 1 = 0` \
                 through it exists; use `point`, `sphere` or `measured`, or edit the spec",
            ))
        } else {
            Ok(())
        }
    };
    let named = |names: &[&str], vals: &[f64]| -> Vec<(String, String)> {
        names
            .iter()
            .zip(vals)
            .map(|(n, v)| ((*n).to_string(), num(*v)))
            .collect()
    };
    Ok(match choice {
        ConstraintChoice::Measured => ("constraint: measured\n".into(), Vec::new()),
        ConstraintChoice::MeasuredPose => ("constraint: measured_pose\n".into(), Vec::new()),
        ConstraintChoice::Point => (
            "constraint:\n  point: {p: [px, py, pz]}\n".into(),
            named(&["px", "py", "pz"], &tip),
        ),
        ConstraintChoice::Sphere => (
            "constraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n".into(),
            named(
                &["cx", "cy", "cz", "r"],
                &[tip[0], tip[1], tip[2] - 0.1, 0.1],
            ),
        ),
        ConstraintChoice::Plane => {
            need_offset()?;
            let b = plane(tip);
            (
                "constraint:\n  plane: {b: [b1, b2, b3]}\n".into(),
                named(&["b1", "b2", "b3"], &b),
            )
        }
        ConstraintChoice::Line => {
            need_offset()?;
            let b1 = plane(tip);
            let mut w = cross(tip, [0.0, 0.0, 1.0]);
            if norm(w) < 1e-6 * p2.sqrt() {
                w = cross(tip, [1.0, 0.0, 0.0]);
            }
            let w = unit(w);
            let s = 1.0 / p2.sqrt();
            let b2 = [b1[0] + s * w[0], b1[1] + s * w[1], b1[2] + s * w[2]];
            (
                "constraint:\n  line: {planes: [[b11, b12, b13], [b21, b22, b23]]}\n".into(),
                named(
                    &["b11", "b12", "b13", "b21", "b22", "b23"],
                    &[b1[0], b1[1], b1[2], b2[0], b2[1], b2[2]],
                ),
            )
        }
    })
}

#[cfg(test)]
mod tests {
    use super::position_name_clashes;

    #[test]
    fn a_joint_named_after_another_position_is_noted() {
        let names = |v: &[&str]| v.iter().map(|s| (*s).to_string()).collect::<Vec<_>>();
        let notes = position_name_clashes(&names(&["q2", "q1", "q3", "wrist"]));
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(
            notes[0].contains("joint 1 of the chain is named `q2`"),
            "{notes:?}"
        );
        assert!(notes[0].contains("head joint 1's column `q1`"), "{notes:?}");
        // Its own position's name, other names and `q0`/`q01` clash with nothing.
        assert!(position_name_clashes(&names(&["q1", "q01", "q0", "elbow"])).is_empty());
        assert!(position_name_clashes(&names(&["q7", "q2"])).is_empty());
    }
}
