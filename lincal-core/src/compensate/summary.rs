//! The summary of a run of targets: counts per status, the failed rows with their CSV lines,
//! the largest correction, residual and `σ`; as text (stderr) or one JSON object.

use super::verdict::Status;
use super::Outcome;
use serde_json::{json, Value};

/// The rows named in a summary's list of the largest corrections.
const WORST: usize = 5;
/// Failed rows named in the text summary (the JSON lists them all).
const TEXT_FAILURES: usize = 20;

/// One row named in a summary.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// 0-based target index.
    pub target: usize,
    /// Its CSV line (1-based).
    pub line: usize,
    /// Its status.
    pub status: Status,
    /// Why it failed (empty for `ok`).
    pub message: String,
    /// `‖q′ − q₀‖`.
    pub correction: f64,
    /// Position residual, metres.
    pub residual: f64,
    /// Predicted position uncertainty, metres.
    pub sigma: f64,
}

/// Counts and worst rows of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Targets.
    pub targets: usize,
    /// Targets per status, in [`Status::ALL`] order.
    pub counts: [usize; 5],
    /// The failed rows, in input order.
    pub failures: Vec<Row>,
    /// The rows of largest correction, descending (at most 5).
    pub worst: Vec<Row>,
    /// RMS correction over the `ok` rows.
    pub correction_rms: f64,
    /// Largest position residual over the `ok` rows, metres.
    pub residual_max: f64,
    /// Mean and largest `σ` over the `ok` rows, metres.
    pub sigma_mean: f64,
    /// Largest `σ` over the `ok` rows, metres.
    pub sigma_max: f64,
}

impl Summary {
    /// The summary of `outcomes`, row `l` at CSV line `line(l)`.
    #[must_use]
    pub fn new(outcomes: &[Outcome], line: impl Fn(usize) -> usize) -> Self {
        let row = |l: usize| {
            let o = &outcomes[l];
            Row {
                target: l,
                line: line(l),
                status: o.verdict.status,
                message: o.verdict.message.clone(),
                correction: o.correction,
                residual: o.residual,
                sigma: o.sigma,
            }
        };
        let mut counts = [0; 5];
        let (mut c2, mut rmax, mut ssum, mut smax, mut ok) = (0.0, 0.0_f64, 0.0, 0.0_f64, 0);
        for o in outcomes {
            let k = Status::ALL
                .iter()
                .position(|s| *s == o.verdict.status)
                .unwrap_or(0);
            counts[k] += 1;
            if o.verdict.status == Status::Ok {
                ok += 1;
                c2 += o.correction * o.correction;
                rmax = rmax.max(o.residual);
                ssum += o.sigma;
                smax = smax.max(o.sigma);
            }
        }
        let mut order: Vec<usize> = (0..outcomes.len()).collect();
        order.sort_by(|&a, &b| outcomes[b].correction.total_cmp(&outcomes[a].correction));
        let okf = ok.max(1) as f64;
        Summary {
            targets: outcomes.len(),
            counts,
            failures: (0..outcomes.len())
                .filter(|&l| outcomes[l].verdict.status != Status::Ok)
                .map(row)
                .collect(),
            worst: order.into_iter().take(WORST).map(row).collect(),
            correction_rms: (c2 / okf).sqrt(),
            residual_max: rmax,
            sigma_mean: ssum / okf,
            sigma_max: smax,
        }
    }

    /// Targets that failed.
    #[must_use]
    pub fn failed(&self) -> usize {
        self.targets - self.counts[0]
    }

    /// The text summary (lines for stderr).
    #[must_use]
    pub fn to_text(&self) -> String {
        let counts: Vec<String> = Status::ALL
            .iter()
            .zip(self.counts)
            .map(|(s, c)| format!("{c} {}", s.as_str()))
            .collect();
        let mut t = format!("{} targets: {}\n", self.targets, counts.join(", "));
        if self.counts[0] == 0 {
            t += "  ok rows: none\n";
        } else {
            t += &format!(
                "  ok rows: correction rms {:.3e}, residual max {:.3e} m, sigma mean {:.3e} m, \
                 max {:.3e} m\n",
                self.correction_rms, self.residual_max, self.sigma_mean, self.sigma_max
            );
        }
        if !self.worst.is_empty() {
            t += "  largest corrections:";
            for r in &self.worst {
                t += &format!(
                    " line {} ({:.3e}, {})",
                    r.line,
                    r.correction,
                    r.status.as_str()
                );
            }
            t += "\n";
        }
        for r in self.failures.iter().take(TEXT_FAILURES) {
            t += &format!(
                "  line {} (target {}): {}: {}\n",
                r.line,
                r.target,
                r.status.as_str(),
                r.message
            );
        }
        if self.failures.len() > TEXT_FAILURES {
            t += &format!(
                "  … and {} more failed rows (their status column says which)\n",
                self.failures.len() - TEXT_FAILURES
            );
        }
        t
    }

    /// The JSON summary: `targets`, `counts` (per status), `failed`, `correction_rms`,
    /// `residual_max`, `sigma_mean`, `sigma_max`, `worst` and `failures` (rows
    /// `{target, line, status, message, correction, residual, sigma}`).
    #[must_use]
    pub fn to_json(&self) -> Value {
        let row = |r: &Row| {
            json!({
                "target": r.target,
                "line": r.line,
                "status": r.status.as_str(),
                "message": r.message,
                "correction": finite(r.correction),
                "residual": finite(r.residual),
                "sigma": finite(r.sigma),
            })
        };
        let counts: serde_json::Map<String, Value> = Status::ALL
            .iter()
            .zip(self.counts)
            .map(|(s, c)| (s.as_str().to_string(), json!(c)))
            .collect();
        json!({
            "targets": self.targets,
            "counts": counts,
            "failed": self.failed(),
            "correction_rms": finite(self.correction_rms),
            "residual_max": finite(self.residual_max),
            "sigma_mean": finite(self.sigma_mean),
            "sigma_max": finite(self.sigma_max),
            "worst": self.worst.iter().map(row).collect::<Vec<_>>(),
            "failures": self.failures.iter().map(row).collect::<Vec<_>>(),
        })
    }
}

fn finite(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        Value::Null
    }
}
