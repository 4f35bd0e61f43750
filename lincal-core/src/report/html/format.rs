//! How the report writes text and numbers: HTML escaping, numbers for tables and axes,
//! lengths with a readable unit, and the RMS of residuals.
//!
//! Takes strings and numbers; gives their text.

/// `s` with the characters HTML gives a meaning escaped.
#[must_use]
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// A number for a table: about 10 significant digits, `—` when not finite.
pub(crate) fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        return "—".to_string();
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let a = v.abs();
    if (1e-4..1e6).contains(&a) {
        let digits = (9 - a.log10().floor() as i32).clamp(0, 15) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.6e}")
    }
}

/// A short number (4 significant digits), `—` when not finite.
pub(crate) fn fmt_short(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else if v.is_finite() {
        format!("{v:.3e}")
    } else {
        "—".to_string()
    }
}

/// An axis tick: at most 3 decimals, trailing zeros dropped.
pub(crate) fn tick(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// A length with a readable unit (`12.3 µm`), `—` when not finite.
pub(crate) fn fmt_len(v: f64) -> String {
    if !v.is_finite() {
        return "—".to_string();
    }
    let (f, u) = unit(v.abs());
    format!("{:.4} {u}", v * f)
}

/// Factor and unit to show lengths of about `m` metres.
pub(crate) fn unit(m: f64) -> (f64, &'static str) {
    if !(m.is_finite() && m > 0.0) || m >= 1.0 {
        (1.0, "m")
    } else if m >= 1e-3 {
        (1e3, "mm")
    } else if m >= 1e-6 {
        (1e6, "µm")
    } else {
        (1e9, "nm")
    }
}

/// RMS of the finite values and how many were not finite.
pub(crate) fn rms(v: &[f64]) -> (f64, usize) {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if finite.is_empty() {
        return (f64::NAN, v.len());
    }
    let s: f64 = finite.iter().map(|x| x * x).sum();
    ((s / finite.len() as f64).sqrt(), v.len() - finite.len())
}
