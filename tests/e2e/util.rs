//! Helpers: run the `lincal` binary, temporary files, a tiny expression evaluator for the
//! checks of `shared/cases/*/expected.json`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// The result of one `lincal` run.
pub struct Run {
    /// Exit status (`-1` when killed by a signal).
    pub code: i32,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
}

impl Run {
    /// Stdout parsed as JSON (panics with the run's output when it is not).
    pub fn json(&self) -> Value {
        serde_json::from_str(&self.stdout).unwrap_or_else(|e| {
            panic!(
                "stdout is not JSON ({e}); status {}\nstdout:\n{}\nstderr:\n{}",
                self.code, self.stdout, self.stderr
            )
        })
    }

    /// Asserts exit status 0.
    pub fn ok(self) -> Self {
        assert_eq!(self.code, 0, "expected success; stderr:\n{}", self.stderr);
        self
    }

    /// Asserts an exit status and that stderr holds every needle.
    pub fn fails(self, code: i32, needles: &[&str]) -> Self {
        assert_eq!(
            self.code, code,
            "expected exit status {code}\nstdout:\n{}\nstderr:\n{}",
            self.stdout, self.stderr
        );
        for n in needles {
            assert!(
                self.stderr.contains(n),
                "stderr lacks {n:?}:\n{}",
                self.stderr
            );
        }
        assert!(
            !self.stderr.contains("panicked") && !self.stderr.contains("internal error"),
            "a panic:\n{}",
            self.stderr
        );
        self
    }
}

/// Runs `lincal` with `args`, its spec-facts cache in the test run's scratch space (shared
/// by every test: most runs find their spec's facts there, as a user's repeated runs do).
pub fn lincal<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Run {
    let cache = Path::new(env!("CARGO_TARGET_TMPDIR")).join("e2e-cache");
    lincal_with(args, &[("LINCAL_CACHE_DIR", cache.as_os_str())])
}

/// Runs `lincal` with `args` and the environment variables `env`.
pub fn lincal_with<S: AsRef<std::ffi::OsStr>>(args: &[S], env: &[(&str, &std::ffi::OsStr)]) -> Run {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_lincal"));
    for (k, v) in env {
        cmd.env(k, v);
    }
    let out = cmd
        .args(args)
        .output()
        .expect("cannot run the lincal binary");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// A fresh scratch directory for one test.
pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("e2e")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("cannot create a scratch directory");
    dir
}

/// Writes `text` to `dir/name`; the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("cannot write a scratch file");
    p
}

/// `lincal import tests/urdf/ur5_rail.urdf ARGS`, written to `dir/name`.
pub fn import_rail(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let urdf = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/ur5_rail.urdf");
    let mut all = vec!["import", urdf.to_str().unwrap()];
    all.extend_from_slice(args);
    let run = lincal(&all).ok();
    write(dir, name, &run.stdout)
}

/// The rail's whole chain (`world` to `ee_link`) imported in `convention`, written to
/// `dir/name`.
pub fn import_rail_chain(dir: &Path, name: &str, convention: &str) -> PathBuf {
    let args = [
        "--base",
        "world",
        "--tip",
        "ee_link",
        "--convention",
        convention,
    ];
    import_rail(dir, name, &args)
}

/// A spec of `tests/specs/`.
pub fn spec(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/specs")
        .join(name)
}

/// The shared reference cases (`../shared/cases`).
pub fn cases_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/cases"))
}

/// `a` wrapped into `(−π, π]`.
pub fn wrap(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let w = a - TAU * (a / TAU).round();
    if w <= -PI {
        w + TAU
    } else {
        w
    }
}

/// The `value` of every parameter in a calibrate JSON result.
pub fn values(result: &Value) -> HashMap<String, f64> {
    result["params"]
        .as_object()
        .expect("`params` is an object")
        .iter()
        .map(|(k, v)| {
            let x = v["value"]
                .as_f64()
                .unwrap_or_else(|| panic!("params.{k}.value is not a number: {v}"));
            (k.clone(), x)
        })
        .collect()
}

/// Evaluates an arithmetic expression over named values: `+ - * /`, parentheses, numbers,
/// names, `pi`, and `atan2, hypot, sqrt, sin, cos, abs`.
pub fn eval(expr: &str, vars: &HashMap<String, f64>) -> Result<f64, String> {
    let tokens = tokenize(expr)?;
    let mut p = Parser {
        t: &tokens,
        i: 0,
        vars,
    };
    let v = p.sum()?;
    if p.i != tokens.len() {
        return Err(format!("trailing input in `{expr}`"));
    }
    Ok(v)
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(f64),
    Name(String),
    Op(char),
}

fn tokenize(s: &str) -> Result<Vec<Tok>, String> {
    let c: Vec<char> = s.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        if ch.is_whitespace() {
            i += 1;
        } else if ch.is_ascii_digit() || ch == '.' {
            let start = i;
            while i < c.len()
                && (c[i].is_ascii_digit()
                    || c[i] == '.'
                    || c[i] == 'e'
                    || c[i] == 'E'
                    || ((c[i] == '-' || c[i] == '+') && (c[i - 1] == 'e' || c[i - 1] == 'E')))
            {
                i += 1;
            }
            let text: String = c[start..i].iter().collect();
            out.push(Tok::Num(
                text.parse().map_err(|_| format!("bad number `{text}`"))?,
            ));
        } else if ch.is_ascii_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_ascii_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(Tok::Name(c[start..i].iter().collect()));
        } else if "+-*/(),".contains(ch) {
            out.push(Tok::Op(ch));
            i += 1;
        } else {
            return Err(format!("unexpected `{ch}` in `{s}`"));
        }
    }
    Ok(out)
}

struct Parser<'a> {
    t: &'a [Tok],
    i: usize,
    vars: &'a HashMap<String, f64>,
}

impl Parser<'_> {
    fn peek_op(&self, op: char) -> bool {
        self.t.get(self.i) == Some(&Tok::Op(op))
    }

    fn expect(&mut self, op: char) -> Result<(), String> {
        if self.peek_op(op) {
            self.i += 1;
            Ok(())
        } else {
            Err(format!("expected `{op}` at token {}", self.i))
        }
    }

    fn sum(&mut self) -> Result<f64, String> {
        let mut v = self.product()?;
        loop {
            if self.peek_op('+') {
                self.i += 1;
                v += self.product()?;
            } else if self.peek_op('-') {
                self.i += 1;
                v -= self.product()?;
            } else {
                return Ok(v);
            }
        }
    }

    fn product(&mut self) -> Result<f64, String> {
        let mut v = self.unary()?;
        loop {
            if self.peek_op('*') {
                self.i += 1;
                v *= self.unary()?;
            } else if self.peek_op('/') {
                self.i += 1;
                v /= self.unary()?;
            } else {
                return Ok(v);
            }
        }
    }

    fn unary(&mut self) -> Result<f64, String> {
        if self.peek_op('-') {
            self.i += 1;
            return Ok(-self.unary()?);
        }
        if self.peek_op('+') {
            self.i += 1;
            return self.unary();
        }
        self.atom()
    }

    fn atom(&mut self) -> Result<f64, String> {
        match self.t.get(self.i).cloned() {
            Some(Tok::Num(v)) => {
                self.i += 1;
                Ok(v)
            }
            Some(Tok::Op('(')) => {
                self.i += 1;
                let v = self.sum()?;
                self.expect(')')?;
                Ok(v)
            }
            Some(Tok::Name(n)) => {
                self.i += 1;
                if self.peek_op('(') {
                    self.i += 1;
                    let mut args = vec![self.sum()?];
                    while self.peek_op(',') {
                        self.i += 1;
                        args.push(self.sum()?);
                    }
                    self.expect(')')?;
                    let f = |k: usize| -> Result<(), String> {
                        if args.len() == k {
                            Ok(())
                        } else {
                            Err(format!("{n} takes {k} argument(s)"))
                        }
                    };
                    match n.as_str() {
                        "atan2" => f(2).map(|()| args[0].atan2(args[1])),
                        "hypot" => f(2).map(|()| args[0].hypot(args[1])),
                        "sqrt" => f(1).map(|()| args[0].sqrt()),
                        "sin" => f(1).map(|()| args[0].sin()),
                        "cos" => f(1).map(|()| args[0].cos()),
                        "abs" => f(1).map(|()| args[0].abs()),
                        _ => Err(format!("unknown function `{n}`")),
                    }
                } else if n == "pi" && !self.vars.contains_key("pi") {
                    Ok(std::f64::consts::PI)
                } else {
                    self.vars
                        .get(&n)
                        .copied()
                        .ok_or_else(|| format!("unknown name `{n}`"))
                }
            }
            other => Err(format!("unexpected {other:?} at token {}", self.i)),
        }
    }
}

/// One gauge-invariant check: an expression, its true value, a tolerance, and whether it is
/// an angle (compared modulo 2π).
pub struct Check<'a> {
    /// The expression.
    pub expr: &'a str,
    /// Its true value.
    pub truth: f64,
    /// Largest allowed `|result − truth|`.
    pub tol: f64,
    /// Compare the difference wrapped into (−π, π].
    pub rad: bool,
}

/// Evaluates every check on `vars`; a list of the failures (empty when all pass).
pub fn failed_checks(checks: &[Check<'_>], vars: &HashMap<String, f64>) -> Vec<String> {
    let mut bad = Vec::new();
    for c in checks {
        match eval(c.expr, vars) {
            Ok(v) => {
                let d = if c.rad {
                    wrap(v - c.truth)
                } else {
                    v - c.truth
                };
                if d.is_nan() || d.abs() > c.tol {
                    bad.push(format!(
                        "{}: got {v}, true {}, |diff| {:e} > {:e}",
                        c.expr,
                        c.truth,
                        d.abs(),
                        c.tol
                    ));
                }
            }
            Err(e) => bad.push(format!("{}: {e}", c.expr)),
        }
    }
    bad
}

#[test]
fn evaluator() {
    let vars: HashMap<String, f64> = [("a1".to_string(), 2.0), ("b_2".to_string(), 3.0)]
        .into_iter()
        .collect();
    let close = |e: &str, v: f64| {
        let got = eval(e, &vars).unwrap();
        assert!((got - v).abs() < 1e-12, "{e} = {got}, expected {v}");
    };
    close("a1 + b_2 * 2", 8.0);
    close("(a1 + b_2) * 2", 10.0);
    close("-a1 - -b_2", 1.0);
    close("a1/b_2/2", 1.0 / 3.0);
    close("hypot(a1, b_2)", 13f64.sqrt());
    close(
        "atan2(1, -1) + abs(-2)",
        3.0 * std::f64::consts::FRAC_PI_4 + 2.0,
    );
    close("sqrt(4) + sin(0) + cos(0)", 3.0);
    close("1.5e-3*1000", 1.5);
    close("pi", std::f64::consts::PI);
    assert!(eval("a1 +", &vars).is_err());
    assert!(eval("zz", &vars).is_err());
    assert!(eval("foo(1)", &vars).is_err());
    assert!((wrap(2.0 * std::f64::consts::PI + 0.1) - 0.1).abs() < 1e-12);
    assert!((wrap(-std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
}

/// The `name: value` lines of a truth file written by `simulate --truth-out`.
pub fn truth_values(path: &Path) -> Vec<(String, f64)> {
    std::fs::read_to_string(path)
        .expect("the truth file")
        .lines()
        .map(|line| {
            let (name, v) = line.split_once(':').expect("name: value");
            (name.to_string(), v.trim().parse().expect("a number"))
        })
        .collect()
}

/// Asserts that the estimate of `name` is within 5 of its standard deviations of the truth
/// `t`, and that the standard deviation is below `max_std`.
pub fn within_5_std(result: &Value, name: &str, t: f64, max_std: f64) {
    let value = result["params"][name]["value"].as_f64().expect("a value");
    let std = result["params"][name]["std"].as_f64().expect("a std");
    assert!(
        (value - t).abs() < 5.0 * std && std < max_std,
        "{name}: {value} ± {std} vs truth {t}"
    );
}

/// `lincal simulate SPEC --poses N --seed S NOISE --truth-out TRUTH`: the CSV.
pub fn simulate(spec: &str, poses: usize, seed: u64, noise: [&str; 2], truth: &Path) -> String {
    let (poses, seed) = (poses.to_string(), seed.to_string());
    lincal(&[
        "simulate",
        spec,
        "--poses",
        &poses,
        "--seed",
        &seed,
        noise[0],
        noise[1],
        "--truth-out",
        truth.to_str().unwrap(),
    ])
    .ok()
    .stdout
}

/// `lincal calibrate SPEC DATA --refine --format json`, parsed.
/// The prior of fits of simulated data that check a recovered truth: fixed tolerances of
/// `simulate`'s perturbation size (1 cm, 0.01 rad). Simulated data have no model error: a
/// fixed, Bayesian prior fades with the poses, where the default relative one keeps its pull
/// (docs/03-calibrating.md, *The prior*).
pub const FIXED_PRIOR: [&str; 4] = ["--tolerance-length", "0.01", "--tolerance-angle", "0.01"];

pub fn calibrate_refined(spec: &str, data: &Path) -> Value {
    lincal(&[
        "calibrate",
        spec,
        data.to_str().unwrap(),
        "--refine",
        "--format",
        "json",
        FIXED_PRIOR[0],
        FIXED_PRIOR[1],
        FIXED_PRIOR[2],
        FIXED_PRIOR[3],
    ])
    .ok()
    .json()
}
