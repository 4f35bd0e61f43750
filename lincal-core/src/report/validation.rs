//! Held-out validation and cross-validation as readable text: the section `lincal evaluate`
//! prints, and that `lincal calibrate --validate/--folds` appends.

use std::fmt::Write as _;

use crate::calibrate::validation::{CrossValidation, Evaluation};

fn m(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3e}")
    } else {
        "–".to_string()
    }
}

fn vector(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x:.6}")).collect();
    format!("({})", parts.join(", "))
}

/// One held-out data set, nominal beside the given parameters (`label` names the latter,
/// `calibrated` or `given`).
#[must_use]
pub fn evaluation_text(e: &Evaluation, label: &str) -> String {
    let mut s = String::new();
    let files = if e.files.is_empty() {
        String::new()
    } else {
        format!(" ({})", e.files.join(", "))
    };
    let _ = writeln!(
        s,
        "held-out poses: {}{files}; unknown constraint values refitted to the held-out tips",
        e.poses
    );
    let _ = writeln!(
        s,
        "  residual rms (nominal → {label}): {} → {} m",
        m(e.residual_rms_nominal),
        m(e.residual_rms)
    );
    if let (Some(a), Some(b)) = (e.spread_pooled_nominal, e.spread_pooled) {
        let _ = writeln!(s, "  spread pooled over the points: {} → {} m", m(a), m(b));
    }
    if let Some(o) = &e.orientation {
        orientation_line(&mut s, o);
    }
    for c in &e.constraints {
        let _ = writeln!(
            s,
            "  {} {} ({} poses): residual rms {} → {} m, max {} → {} m",
            c.constraint,
            c.kind,
            c.poses,
            m(c.residual_rms_nominal),
            m(c.residual_rms),
            m(c.max_residual_nominal),
            m(c.max_residual)
        );
        if c.residual_dof == 0 && c.poses > 0 && !c.refitted.is_empty() {
            let _ = writeln!(
                s,
                "    says nothing: the refitted values fit these {} poses exactly whatever the \
                 parameters; hold out more poses on this constraint",
                c.poses
            );
        }
        if let (Some(a), Some(b)) = (c.spread_nominal, c.spread) {
            let _ = writeln!(s, "    spread {} → {} m", m(a), m(b));
        }
        if let (Some(a), Some(b)) = (&c.mean_nominal, &c.mean) {
            let _ = writeln!(s, "    mean tip {} → {} m", vector(a), vector(b));
        }
        if !c.refitted.is_empty() {
            let _ = writeln!(s, "    refitted: {}", c.refitted.join(", "));
        }
    }
    for p in &e.point_pairs {
        let [i, j] = p.between;
        let stated = p
            .value
            .map_or_else(String::new, |v| format!(" (stated {} m)", super::stated(v)));
        let _ = write!(
            s,
            "  distance between the mean tips of {i} and {j}{stated}: {:.6} → {:.6} m",
            p.distance_nominal, p.distance
        );
        if let (Some(a), Some(b)) = (p.error_nominal, p.error) {
            let _ = write!(s, "; error {} → {} m", m(a), m(b));
        }
        s.push('\n');
    }
    s
}

/// The held-out measured poses' orientation figures, one line.
fn orientation_line(s: &mut String, o: &crate::calibrate::validation::OrientationEvaluation) {
    let _ = writeln!(
        s,
        "  orientation rms ({} measured poses): {} → {} rad, max {} → {} rad; pose rms with the \
         weight {} m/rad: {} → {} m",
        o.poses,
        m(o.orientation_rms_nominal),
        m(o.orientation_rms),
        m(o.max_orientation_nominal),
        m(o.max_orientation),
        m(o.weight),
        m(o.pose_rms_nominal),
        m(o.pose_rms)
    );
}

/// `, N not scored` (the poses a refit fits exactly), or nothing.
fn unscored(n: usize) -> String {
    if n == 0 {
        String::new()
    } else {
        format!(", {n} not scored")
    }
}

/// The cross-validation's folds and means.
#[must_use]
pub fn cross_validation_text(cv: &CrossValidation) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "cross-validation ({} folds{}, {}): residual rms in-sample {} m, held-out {} m \
         (mean over folds {} m; training fits {} m)",
        cv.folds,
        if cv.folds < cv.folds_asked {
            format!(" of {} asked", cv.folds_asked)
        } else {
            String::new()
        },
        cv.split,
        m(cv.residual_rms_in_sample),
        m(cv.residual_rms_held_out),
        m(cv.residual_rms_held_out_mean),
        m(cv.residual_rms_train_mean)
    );
    if let Some(note) = &cv.split_note {
        let _ = writeln!(s, "  split {note}");
    }
    for f in &cv.per_fold {
        let _ = writeln!(
            s,
            "  fold {}: fitted on {} poses (rms {} m), held out {} poses{}: rms {} m, max {} m",
            f.fold,
            f.train_poses,
            m(f.residual_rms_train),
            f.test_poses,
            unscored(f.unscored_poses),
            m(f.residual_rms_test),
            m(f.max_residual_test)
        );
    }
    for f in &cv.skipped {
        let _ = writeln!(
            s,
            "  fold {}: skipped, its fit on {} poses is undeterminable; its {} held-out poses \
             not scored",
            f.fold, f.train_poses, f.test_poses
        );
    }
    if cv.constraints.len() > 1 {
        for c in &cv.constraints {
            let _ = writeln!(
                s,
                "  constraint {} {} ({} poses{}): held-out rms {} m",
                c.constraint,
                c.kind,
                c.poses,
                unscored(c.unscored_poses),
                m(c.residual_rms_held_out)
            );
        }
    }
    s
}
