//! Calibrated spec → URDF: new `<origin>`s for the chain's joints, everything else kept.
//!
//! With `U_i` the URDF frame of moving joint `i` at zero readings and `Z_i` the spec's zero
//! frame ([`super::numeric`]), the import made `U_i·C_i = Z_i` with a constant `C_i` whose
//! z axis is the URDF axis and whose origin is on it, so that `U_i·M_i(q)·C_i = Z_i·Rz(q)`
//! (or `·Tz(q)`) for every reading. `C_i` is computed again from the original URDF (the
//! import is deterministic) with the nominal spec; the calibrated frames are then
//! `U_i' = Z_i'·C_i⁻¹`, home offsets included (`Z_i` holds `Rz(−home_i)`), so the readings
//! keep their meaning and the URDF needs no `<calibration>` tag. Joint `i`'s new origin is
//! `O_i' = (U_{i−1}'·G)⁻¹·U_i'`, `G` the fixed joints in between (unchanged). The tip
//! point's place after the last joint, `t' = Z_n'⁻¹·x'(0)`, goes into the translation of the
//! last fixed joint after the last moving joint (`tool0`, `ee_link`, ...), whose rotation is
//! kept. Without such a joint a tip that moved relative to the last axis cannot be written,
//! and the export says so.
//!
//! The new file is the old text with only those `<origin>` elements replaced (or inserted),
//! and is checked by reading it back: its tip must equal the calibrated model's at random
//! readings (to 10⁻⁹ m, else an internal error; 10⁻¹² is typical).

use super::chain::UrdfChain;
use super::frame::{norm, Iso};
use super::import::{import, ConstraintChoice, ImportOptions};
use super::numeric::{worst_tip_gap, NumChain};
use super::record::UrdfRecord;
use super::xml::XmlIndex;
use crate::error::{Error, ErrorClass, Location, Result};
use crate::spec::Spec;

/// The URDF `urdf_text` (the file `urdf_file` the spec's record names) with the joint
/// origins of the calibrated `spec`; `value(name)` gives each parameter's calibrated value.
///
/// # Errors
/// An input error when the URDF no longer has the recorded chain (joints renamed, types
/// changed) or the spec's joints do not match it; a degenerate error when the calibrated
/// tip cannot be written (no fixed joint after the last moving one); an internal error when
/// the written file does not reproduce the model (a bug).
pub fn write_urdf(
    urdf_text: &str,
    urdf_file: &str,
    record: &UrdfRecord,
    spec: &Spec,
    value: &dyn Fn(&str) -> Option<f64>,
) -> Result<String> {
    // A UTF-8 byte-order mark is kept in front of the output, and every offset is taken on
    // the text after it: the one the edits are applied to.
    let (bom, urdf_text) = match urdf_text.strip_prefix('\u{feff}') {
        Some(rest) => ("\u{feff}", rest),
        None => ("", urdf_text),
    };
    // The chain's ends come from the spec's record here, not from `import`'s options.
    let chain =
        UrdfChain::from_str(urdf_text, urdf_file, &record.base, &record.tip).map_err(|e| {
            e.field_renamed("--base", "urdf.base (the spec's record)")
                .field_renamed("--tip", "urdf.tip (the spec's record)")
        })?;
    check_recorded_joints(&chain, record, urdf_file)?;
    let cal = NumChain::from_spec(spec, value)?;
    let nom = nominal_chain(urdf_text, urdf_file, record, spec)?;
    let kinds_match = spec.dim == 3
        && cal.joint_count() == nom.joint_count()
        && (0..cal.joint_count()).all(|i| cal.is_prismatic(i) == nom.is_prismatic(i));
    if !kinds_match {
        return Err(Error::input(
            Location {
                field: Some("joints".into()),
                ..Location::default()
            },
            format!(
                "the spec's joints (their number and types) are not those of the chain `{}` -> \
                 `{}` of `{urdf_file}` that its `urdf:` record names",
                record.base, record.tip
            ),
        ));
    }
    let origins = new_origins(&chain, record, &cal, &nom)?;
    check_origin_sizes(&chain, &origins, urdf_file)?;
    let out = replace_origins(urdf_text, urdf_file, &chain, &origins)?;
    check_well_formed(&out, urdf_file)?;
    check_read_back(&out, urdf_file, record, &cal)?;
    Ok(format!("{bom}{out}"))
}

/// Every new origin lies within [`super::chain::MAX_LENGTH`] of its parent, the bound a URDF
/// is read with: a calibration that put a joint further (a chain near that bound, or a fit
/// that ran off) is a degenerate error naming the joint, not a file that cannot be read back.
fn check_origin_sizes(chain: &UrdfChain, origins: &[(usize, Iso)], urdf_file: &str) -> Result<()> {
    let max = super::chain::MAX_LENGTH;
    for (idx, o) in origins {
        if o.t.iter().any(|v| !v.is_finite() || v.abs() > max) {
            let name = chain.elements.get(*idx).map_or("?", |e| e.name.as_str());
            return Err(Error::degenerate(format!(
                "the calibrated origin of joint `{name}` would be at xyz {:?}, beyond the \
                 {max:e} m a URDF origin may hold (the URDF `{urdf_file}` is not written): \
                 check the calibration's result before using it",
                o.t
            )));
        }
    }
    Ok(())
}

/// The written text parses as a conforming XML parser reads it: one well-formed document
/// (matching tags, the declaration first, nothing after the root), else an internal error.
fn check_well_formed(out: &str, urdf_file: &str) -> Result<()> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(out);
    reader.config_mut().check_end_names = true;
    let (mut depth, mut roots, mut seen) = (0usize, 0usize, false);
    loop {
        let event = reader.read_event().map_err(|e| {
            Error::other(format!(
                "the written URDF for `{urdf_file}` is not well-formed XML (a bug): {e}"
            ))
        })?;
        let bad = |what: &str| {
            Error::other(format!(
                "the written URDF for `{urdf_file}` is not well-formed XML (a bug): {what}"
            ))
        };
        match event {
            Event::Decl(_) if seen => return Err(bad("an XML declaration after content")),
            Event::Start(_) => {
                if depth == 0 {
                    roots += 1;
                }
                depth += 1;
            }
            Event::Empty(_) if depth == 0 => roots += 1,
            Event::End(_) => depth = depth.saturating_sub(1),
            Event::Text(t) if depth == 0 && !t.iter().all(u8::is_ascii_whitespace) => {
                return Err(bad("text outside the root element"))
            }
            Event::DocType(_) if roots > 0 => return Err(bad("a DOCTYPE after the root")),
            Event::Eof => break,
            _ => {}
        }
        seen = true;
    }
    if roots != 1 || depth != 0 {
        return Err(Error::other(format!(
            "the written URDF for `{urdf_file}` is not one XML document (a bug)"
        )));
    }
    Ok(())
}

/// The URDF still has the moving joints the spec's record names, in order.
fn check_recorded_joints(chain: &UrdfChain, record: &UrdfRecord, urdf_file: &str) -> Result<()> {
    let moving: Vec<&str> = chain.actuated().map(|e| e.name.as_str()).collect();
    if moving != record.joints.iter().map(String::as_str).collect::<Vec<_>>() {
        return Err(Error::input(
            Location {
                field: Some("urdf.joints".into()),
                ..Location::default()
            },
            format!(
                "the spec records the joints [{}] but `{urdf_file}` now has [{}] between `{}` and \
                 `{}`: import the URDF again",
                record.joints.join(", "),
                moving.join(", "),
                record.base,
                record.tip
            ),
        ));
    }
    Ok(())
}

/// The nominal chain: the URDF imported again as the record says (the import is
/// deterministic, so this is the table the spec started from), at its nominals.
fn nominal_chain(
    urdf_text: &str,
    urdf_file: &str,
    record: &UrdfRecord,
    spec: &Spec,
) -> Result<NumChain> {
    let nom_spec = nominal_spec(urdf_text, urdf_file, record, spec)?;
    NumChain::from_spec(&nom_spec, &|n| {
        nom_spec.param(n).map(|p| p.nominal.to_f64())
    })
}

/// The spec `lincal import` makes of the record's chain in `spec`'s convention: its nominals
/// are the URDF's own.
fn nominal_spec(
    urdf_text: &str,
    urdf_file: &str,
    record: &UrdfRecord,
    spec: &Spec,
) -> Result<Spec> {
    let nominal = import(
        urdf_text,
        urdf_file,
        &ImportOptions {
            path: record.path.clone(),
            base: record.base.clone(),
            tip: record.tip.clone(),
            tool: record.tool,
            convention: spec.convention,
            constraint: ConstraintChoice::Measured,
            points: 1,
            distances: Vec::new(),
            command: String::new(),
        },
    )?;
    crate::spec::from_yaml_str(&nominal.yaml, None)
}

/// The values the URDF itself gives `spec`'s `base:` parameters, by name: slot by slot,
/// the re-import's (its nominals, or its numbers). With them [`write_urdf`] keeps the URDF's
/// own placement of the chain's first joint, whatever the spec's `base:` was fitted to or
/// guessed (a laser tracker's registration is left out: `calibrate --urdf-base urdf`).
///
/// # Errors
/// As [`write_urdf`]'s, when the URDF no longer has the recorded chain.
pub fn urdf_base_values(
    urdf_text: &str,
    urdf_file: &str,
    record: &UrdfRecord,
    spec: &Spec,
) -> Result<Vec<(String, f64)>> {
    let urdf_text = urdf_text.strip_prefix('\u{feff}').unwrap_or(urdf_text);
    let nom = nominal_spec(urdf_text, urdf_file, record, spec)?;
    let (Some(b), Some(nb)) = (&spec.base, &nom.base) else {
        return Ok(Vec::new());
    };
    let value = |s: &crate::spec::Slot| match s {
        crate::spec::Slot::Const(e) => Some(e.to_f64()),
        crate::spec::Slot::Param(n) => nom.param(n).map(|p| p.nominal.to_f64()),
    };
    Ok(b.slots()
        .into_iter()
        .zip(nb.slots())
        .filter_map(|((_, s), (_, ns))| Some((s.param()?.to_string(), value(ns)?)))
        .collect())
}

/// The new `<origin>` of each chain element that changes, by element index: every moving
/// joint's (`O_i' = (U_{i−1}'·G)⁻¹·U_i'`) and the tip's place in the last fixed joint
/// after the last moving one; a degenerate error when the tip moved and no such joint holds
/// it.
fn new_origins(
    chain: &UrdfChain,
    record: &UrdfRecord,
    cal: &NumChain,
    nom: &NumChain,
) -> Result<Vec<(usize, Iso)>> {
    let n = cal.joint_count();
    let (z_nom, _) = nom.frames(&vec![0.0; n]);
    let (z_cal, tip_cal) = cal.frames(&vec![0.0; n]);

    // URDF frames at zero readings: U_i of each moving joint.
    let mut u = Vec::with_capacity(n);
    let mut t = Iso::IDENTITY;
    for e in &chain.elements {
        t = t.mul(&e.origin);
        if e.kind != super::chain::ElementKind::Fixed {
            u.push(t);
        }
    }
    let c: Vec<Iso> = u
        .iter()
        .zip(&z_nom)
        .map(|(u, z)| u.inverse().mul(z))
        .collect();
    let u_new: Vec<Iso> = z_cal
        .iter()
        .zip(&c)
        .map(|(z, c)| z.mul(&c.inverse()))
        .collect();

    // New origins, base to tip.
    let last_moving = chain
        .elements
        .iter()
        .rposition(|e| e.kind != super::chain::ElementKind::Fixed)
        .unwrap_or(0);
    let last_fixed = (last_moving + 1..chain.elements.len()).last();
    // The tip point in U_n' coordinates.
    let t_tip = c[n - 1].apply(z_cal[n - 1].inverse().apply(tip_cal));
    let mut origins: Vec<(usize, Iso)> = Vec::new();
    let mut t = Iso::IDENTITY;
    let mut k = 0;
    for (idx, e) in chain.elements.iter().enumerate() {
        let o = if e.kind != super::chain::ElementKind::Fixed {
            let o = t.inverse().mul(&u_new[k]);
            k += 1;
            origins.push((idx, o));
            o
        } else if Some(idx) == last_fixed {
            let pre = u_new[n - 1].inverse().mul(&t);
            let tool = ToolPlace {
                record,
                c_n: &c[n - 1],
                z_n: &z_cal[n - 1],
                tip_cal,
                t_tip,
            };
            let o = tool.origin(cal, &pre, &e.origin);
            origins.push((idx, o));
            o
        } else {
            e.origin
        };
        t = t.mul(&o);
    }
    if last_fixed.is_none() {
        check_tip_unmoved(record, t_tip, n)?;
        if let Some(rot) = cal.tool_rotation() {
            // The tip link is the last joint's frame: its calibrated axes must be the URDF's.
            let turned = c[n - 1].mul(&rot);
            check_tip_unturned(record, &turned, n)?;
        }
    }
    Ok(origins)
}

/// Where the calibrated tool puts the tip link, for the last fixed joint's new origin.
struct ToolPlace<'a> {
    record: &'a UrdfRecord,
    /// `C_n`: the last DH frame in the last moving joint's URDF frame.
    c_n: &'a Iso,
    /// `Z_n'`: the calibrated last DH frame at zero readings.
    z_n: &'a Iso,
    /// The calibrated tip at zero readings.
    tip_cal: [f64; 3],
    /// The tip point in `U_n'` coordinates.
    t_tip: [f64; 3],
}

impl ToolPlace<'_> {
    /// The last fixed joint's origin after the fixed joints `pre` (in `U_n'` coordinates),
    /// its old origin `old`: with a tool frame (measured poses) the tip link
    /// `L = [R | t' − R·tool]` in the last DH frame, so `G_pre⁻¹·C_n·L`; with a tool point
    /// the old rotation and the translation that puts the tip at `t_tip`.
    fn origin(&self, cal: &NumChain, pre: &Iso, old: &Iso) -> Iso {
        let tool = self.record.tool;
        match cal.tool_rotation() {
            Some(rot) => {
                let tp = self.z_n.inverse().apply(self.tip_cal);
                let rt = rot.rotate(tool);
                let link = Iso {
                    r: rot.r,
                    t: [tp[0] - rt[0], tp[1] - rt[1], tp[2] - rt[2]],
                };
                pre.inverse().mul(&self.c_n.mul(&link))
            }
            // G_pre·(R_m, v)·tool = t_tip  ⇒  v = G_pre⁻¹·t_tip − R_m·tool.
            None => {
                let want = pre.inverse().apply(self.t_tip);
                let rt = old.rotate(tool);
                Iso {
                    r: old.r,
                    t: [want[0] - rt[0], want[1] - rt[1], want[2] - rt[2]],
                }
            }
        }
    }
}

/// Without a fixed joint after the last moving one, a calibrated tool frame must keep the
/// last joint's axes (`turned`, the tool frame's rotation in the joint's URDF frame, the
/// identity): a turned tool cannot be written.
fn check_tip_unturned(record: &UrdfRecord, turned: &Iso, n: usize) -> Result<()> {
    let (entries, _) = turned.distance(&Iso::IDENTITY);
    if entries > 1e-12 {
        return Err(Error::new(
            ErrorClass::Degenerate,
            Location::default(),
            format!(
                "the calibrated tool frame turned (a rotation entry by {entries:.3e}) relative to the last joint \
                 `{}`, and the URDF has no fixed joint between it and the tip link `{}` to \
                 hold that: import with `--tip` at a link attached by a fixed joint (a flange \
                 or `tool0`), or mark the tool's angles known",
                record.joints[n - 1],
                record.tip
            ),
        ));
    }
    Ok(())
}

/// Without a fixed joint after the last moving one, the calibrated tip must sit where the
/// record's tool puts it: a tip that moved cannot be written.
fn check_tip_unmoved(record: &UrdfRecord, t_tip: [f64; 3], n: usize) -> Result<()> {
    let moved = norm([
        t_tip[0] - record.tool[0],
        t_tip[1] - record.tool[1],
        t_tip[2] - record.tool[2],
    ]);
    if moved > 1e-12 {
        return Err(Error::new(
            ErrorClass::Degenerate,
            Location::default(),
            format!(
                "the calibrated tip moved {moved:.3e} m relative to the last joint `{}`, and \
                 the URDF has no fixed joint between it and the tip link `{}` to hold that: \
                 import with `--tip` at a link attached by a fixed joint (a flange or \
                 `tool0`), or mark the tool parameters known",
                record.joints[n - 1],
                record.tip
            ),
        ));
    }
    Ok(())
}

/// The URDF text with the `<origin>` of each element in `origins` replaced (or inserted
/// into a joint that has none), and a comment after the prolog saying what changed.
fn replace_origins(
    urdf_text: &str,
    urdf_file: &str,
    chain: &UrdfChain,
    origins: &[(usize, Iso)],
) -> Result<String> {
    let index = XmlIndex::new(urdf_text);
    let mut edits: Vec<(usize, usize, String)> = Vec::new();
    let mut names = Vec::new();
    for (idx, o) in origins {
        let e = &chain.elements[*idx];
        names.push(e.name.clone());
        let span = index.joint(&e.name).ok_or_else(|| {
            Error::other(format!("joint `{}` not found in the URDF text", e.name))
        })?;
        let tag = origin_tag(o);
        match span.origin {
            Some((s, end)) => edits.push((s, end, tag)),
            None if !span.empty => edits.push((span.tag_end, span.tag_end, tag)),
            None => {
                return Err(Error::other(format!(
                    "joint `{}` is an empty element",
                    e.name
                )))
            }
        }
    }
    edits.sort_by_key(|e| e.0);
    let mut out = String::with_capacity(urdf_text.len() + 256);
    let mut at = 0;
    let comment = format!(
        "\n<!-- Written by lincal calibrate (write-urdf): the origins of {} are calibrated (home offsets \
         folded in); everything else is as in {} -->",
        comment_text(&names.join(", ")),
        comment_text(urdf_file)
    );
    out.push_str(&urdf_text[..index.prolog_end]);
    out.push_str(&comment);
    if index.prolog_end == 0 {
        out.push('\n');
    }
    at = at.max(index.prolog_end);
    for (s, e, tag) in edits {
        out.push_str(&urdf_text[at..s]);
        out.push_str(&tag);
        at = e;
    }
    out.push_str(&urdf_text[at..]);
    Ok(out)
}

/// Reads the written text back: its tip must equal the calibrated model's at 20 readings
/// drawn in [−3, 3] by a fixed xorshift sequence (to 10⁻⁹ m, else an internal error).
fn check_read_back(out: &str, urdf_file: &str, record: &UrdfRecord, cal: &NumChain) -> Result<()> {
    let n = cal.joint_count();
    let written = format!("{urdf_file} as written");
    let back = UrdfChain::from_str(out, &written, &record.base, &record.tip)
        .map_err(|e| Error::other(format!("the written URDF does not read back (a bug): {e}")))?;
    let worst = worst_tip_gap(
        n,
        0x2545_f491_4f6c_dd1d,
        |q| cal.tip(q),
        |q| back.tip_frame(q).apply(record.tool),
    );
    if worst > 1e-9 {
        return Err(Error::other(format!(
            "the written URDF's tip differs from the calibrated model's by {worst:.3e} m (a bug)"
        )));
    }
    Ok(())
}

/// `s` made safe inside an XML comment: a comment may not hold `--` nor end in `-`, and no
/// control character is a legal XML character except tab and line ends. So a space breaks
/// every `--`, one follows a final `-`, and control characters (and the line ends, to keep
/// the comment on its line) become `?`. Whatever a URDF's names or paths hold, the comment
/// stays one comment.
pub(crate) fn comment_text(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    for c in s.chars() {
        if c == '-' && out.ends_with('-') {
            out.push(' ');
        }
        out.push(if c.is_control() { '?' } else { c });
    }
    if out.ends_with('-') {
        out.push(' ');
    }
    out
}

/// `<origin xyz="…" rpy="…"/>` with shortest round-trip numbers.
fn origin_tag(o: &Iso) -> String {
    let f = |v: [f64; 3]| {
        v.iter()
            .map(|x| super::num(*x))
            .collect::<Vec<_>>()
            .join(" ")
    };
    format!("<origin xyz=\"{}\" rpy=\"{}\"/>", f(o.t), f(o.rpy()))
}

#[cfg(test)]
mod tests {
    use super::comment_text;
    use quick_xml::events::Event;

    #[test]
    fn comment_text_cannot_close_or_break_a_comment() {
        let hostile = [
            "j1--><!DOCTYPE robot [<!ENTITY xxe SYSTEM \"file:///etc/passwd\">]><!--",
            "a---b",
            "-",
            "x-",
            "--",
            "a\nb\u{1b}]0;title\u{7}",
        ];
        for s in hostile {
            let c = comment_text(s);
            assert!(!c.contains("--") && !c.ends_with('-'), "{c:?}");
            assert!(!c.chars().any(char::is_control), "{c:?}");
            let doc = format!("<r><!--{c}--></r>");
            let mut reader = quick_xml::Reader::from_str(&doc);
            let mut comments = 0;
            loop {
                match reader.read_event().expect("well formed") {
                    Event::Eof => break,
                    Event::Comment(_) => comments += 1,
                    Event::DocType(_) => panic!("a DOCTYPE got out of {s:?}"),
                    _ => {}
                }
            }
            assert_eq!(comments, 1, "{c:?}");
        }
    }
}
