//! Mutation fuzzing in the normal test run: thousands of seeded, mutated specs and CSVs
//! through the library's entry points (load, symbolic model, CSV, calibrate). Every case must
//! end in `Ok` or a located `Err`, within its time budget, without a panic.
//!
//! The seeds are the repo's own specs (`tests/specs`, `lincal-models/specs`, the shared
//! cases) and data simulated from them; the mutations are what hand edits and broken exports
//! do: cut, doubled and swapped lines, stray YAML and CSV tokens, absurd numbers, deep
//! nesting, non-ASCII, tabs and separators.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::time::{Duration, Instant};

use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
use lincal_core::data::Poses;
use lincal_core::simulate::{simulate, Noise};
use lincal_core::symbolic::SymbolicModel;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Spec mutations tried (the issue asks for at least 10 000 specs and CSVs in all).
const SPEC_CASES: usize = 8_000;
/// CSV mutations tried, each calibrated when it loads.
const CSV_CASES: usize = 2_500;
/// The most one case may take (release build; the slowest seen is far below).
const BUDGET: Duration = Duration::from_secs(3);
/// Expansion bound for the mutated specs (a mutation may add joints).
const MAX_TERMS: usize = 50_000;

const TOKENS: &[&str] = &[
    ":",
    "- ",
    "[",
    "]",
    "{",
    "}",
    ",",
    "#",
    "\"",
    "'",
    "&a ",
    "*a",
    "!tag ",
    "---\n",
    "\t",
    "  ",
    "\n",
    "ä",
    "∂",
    "0",
    "-1",
    "1e400",
    "1e160",
    "-1e-320",
    "nan",
    ".inf",
    "pi",
    "2*pi/3",
    "((((((((((1))))))))))",
    "------1",
    "known: true",
    "nominal: ",
    "a1",
    "th9",
    "type: prismatic",
    "revolute",
    "dim: 3",
    "dim: 2",
    "convention: mdh",
    "null",
    "~",
    "0x1F",
    ";",
    "1,5",
];

fn seeds() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut out = Vec::new();
    for dir in ["tests/specs", "lincal-models/specs"] {
        if let Ok(entries) = std::fs::read_dir(root.join(dir)) {
            let mut paths: Vec<_> = entries.flatten().map(|e| e.path()).collect();
            paths.sort();
            for p in paths {
                if p.extension().is_some_and(|e| e == "yaml") {
                    if let Ok(t) = std::fs::read_to_string(&p) {
                        out.push(t);
                    }
                }
            }
        }
    }
    for case in ["adept_line", "planar3_line"] {
        if let Ok(t) =
            std::fs::read_to_string(root.join("../shared/cases").join(case).join("spec.yaml"))
        {
            out.push(t);
        }
    }
    out
}

/// One random edit of `text`.
fn mutate(text: &str, rng: &mut ChaCha8Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        lines.push(String::new());
    }
    let n = lines.len();
    let i = rng.gen_range(0..n);
    match rng.gen_range(0..8) {
        0 => {
            lines.remove(i);
        }
        1 => {
            let l = lines[i].clone();
            lines.insert(i, l);
        }
        2 => {
            let j = rng.gen_range(0..n);
            lines.swap(i, j);
        }
        3 | 4 => {
            // A token at a random character boundary of a line.
            let t = TOKENS[rng.gen_range(0..TOKENS.len())];
            let line = &mut lines[i];
            let cuts: Vec<usize> = line
                .char_indices()
                .map(|(k, _)| k)
                .chain([line.len()])
                .collect();
            let at = cuts[rng.gen_range(0..cuts.len())];
            line.insert_str(at, t);
        }
        5 => {
            // A number replaced by an absurd or odd one.
            let t = [
                "1e400",
                "-0",
                "1e999999999",
                "3e160",
                "0.1e-400",
                "7",
                "-2.5",
                "\"0.375\"",
            ][rng.gen_range(0..8)];
            let line = &mut lines[i];
            if let Some(k) = line.find(|c: char| c.is_ascii_digit()) {
                let end = line[k..]
                    .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == 'e' || c == '-'))
                    .map_or(line.len(), |e| k + e);
                line.replace_range(k..end, t);
            }
        }
        6 => {
            // A cut in the middle of a line.
            let line = &mut lines[i];
            let cuts: Vec<usize> = line.char_indices().map(|(k, _)| k).collect();
            if let Some(&at) = cuts.get(rng.gen_range(0..cuts.len().max(1))) {
                line.truncate(at);
            }
        }
        _ => {
            // Indentation changed.
            let line = &mut lines[i];
            if rng.gen_bool(0.5) {
                line.insert(0, ' ');
            } else if line.starts_with(' ') {
                line.remove(0);
            }
        }
    }
    let mut out = lines.join("\n");
    out.push('\n');
    out
}

/// Runs `f` with a panic caught and the time measured; the failure as text.
fn guarded(what: &str, input: &str, f: impl FnOnce()) -> Option<String> {
    let t = Instant::now();
    let r = catch_unwind(AssertUnwindSafe(f));
    let took = t.elapsed();
    if r.is_err() {
        return Some(format!("{what}: panic on input:\n{input}"));
    }
    (took > BUDGET).then(|| format!("{what}: {took:?} (budget {BUDGET:?}) on input:\n{input}"))
}

#[test]
fn mutated_specs_load_or_fail_located_without_panic() {
    let seeds = seeds();
    assert!(seeds.len() >= 10, "{} seed specs", seeds.len());
    let mut rng = ChaCha8Rng::seed_from_u64(0xf022);
    let mut failures = Vec::new();
    let (mut loaded, mut modelled) = (0, 0);
    for case in 0..SPEC_CASES {
        let mut text = seeds[case % seeds.len()].clone();
        for _ in 0..rng.gen_range(1..4) {
            text = mutate(&text, &mut rng);
        }
        let input = text.clone();
        let fail = guarded("spec", &input, || {
            match lincal_core::spec::from_yaml_str(&text, Some("fuzz.yaml")) {
                Ok(spec) => {
                    loaded += 1;
                    if SymbolicModel::from_spec_with(&spec, MAX_TERMS).is_ok() {
                        modelled += 1;
                    }
                }
                Err(e) => {
                    // Every input error names the file.
                    let msg = e.to_string();
                    assert!(msg.contains("fuzz.yaml"), "unlocated error: {msg}");
                }
            }
        });
        failures.extend(fail);
        if failures.len() > 5 {
            break;
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    // The mutations are not all fatal: a good share still loads and models.
    assert!(
        loaded > SPEC_CASES / 10 && modelled > SPEC_CASES / 20,
        "{loaded} loaded, {modelled} modelled"
    );
}

#[test]
fn mutated_csvs_read_and_calibrate_or_fail_without_panic() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut rng = ChaCha8Rng::seed_from_u64(0xc5f);
    let mut failures = Vec::new();
    let mut calibrated = 0;
    let names = [
        "line_planar4.yaml",
        "measured_spatial.yaml",
        "lines_list.yaml",
        "point_planar3.yaml",
    ];
    let per = CSV_CASES / names.len();
    for name in names {
        let text = std::fs::read_to_string(root.join("tests/specs").join(name)).unwrap();
        let spec = lincal_core::spec::from_yaml_str(&text, None).unwrap();
        let model = SymbolicModel::from_spec(&spec).unwrap();
        let sim = simulate(
            &model,
            &spec,
            40,
            7,
            None,
            Noise {
                track: 1e-5,
                measure: 1e-5,
                ..Noise::default()
            },
        )
        .unwrap();
        let mut csv = Vec::new();
        lincal_core::simulate::write_csv(&mut csv, &model, spec.constraint_list, &sim.poses)
            .unwrap();
        let csv = String::from_utf8(csv).unwrap();
        for _ in 0..per {
            let mut data = csv.clone();
            for _ in 0..rng.gen_range(1..4) {
                data = mutate(&data, &mut rng);
            }
            let input = data.clone();
            let fail = guarded(name, &input, || {
                match Poses::from_csv_str(&data, Some("fuzz.csv"), &model, spec.constraint_list) {
                    Ok(poses) => {
                        if calibrate_spec(&model, &spec, &poses, CalibrateOptions::default())
                            .is_ok()
                        {
                            calibrated += 1;
                        }
                    }
                    Err(e) => {
                        let msg = e.to_string();
                        assert!(msg.contains("fuzz.csv"), "unlocated error: {msg}");
                    }
                }
            });
            failures.extend(fail);
            if failures.len() > 5 {
                break;
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    assert!(calibrated > CSV_CASES / 10, "{calibrated} calibrated");
}
