//! Bad input exits 2 naming the file, line and field; degenerate data exits 1 with the
//! reason; never a panic.

use crate::util::{lincal, scratch, spec, write};

const TWO_LINK: &str = "name: two_link
dim: 2
joints:
  - {type: revolute, a: a1, home: th1}
  - {type: revolute, a: a2, home: th2}
params:
  a1: {nominal: 0.375}
  th1: {nominal: 0.0}
  a2: {nominal: 0.425}
  th2: {nominal: 0.0}
  b1: {nominal: -1.79}
  b2: {nominal: -0.56}
constraint:
  line: {b: [b1, b2]}
";

fn p(path: &std::path::Path) -> String {
    path.display().to_string()
}

#[test]
fn unknown_param_in_a_slot() {
    let dir = scratch("err-unknown-param");
    let bad = TWO_LINK.replace("home: th2}", "home: th9}");
    let s = write(&dir, "spec.yaml", &bad);
    for cmd in ["basis", "simulate"] {
        let mut args = vec![cmd.to_string(), p(&s)];
        if cmd == "simulate" {
            args.extend(["--poses".to_string(), "3".to_string()]);
        }
        lincal(&args).fails(2, &["spec.yaml:5", "th9", "joints[1]"]);
    }
}

#[test]
fn bad_yaml() {
    let dir = scratch("err-bad-yaml");
    let s = write(
        &dir,
        "spec.yaml",
        "name: x\ndim: 2\njoints: [\n  {type: revolute\n",
    );
    lincal(&["basis", &p(&s)]).fails(2, &["spec.yaml:"]);
    let s = write(&dir, "spec2.yaml", &TWO_LINK.replace("dim: 2", "dim: 7"));
    lincal(&["basis", &p(&s), "--format", "json"]).fails(2, &["spec2.yaml:2", "dim"]);
    let s = write(
        &dir,
        "spec3.yaml",
        &TWO_LINK.replace(
            "  b2: {nominal: -0.56}\n",
            "  b2: {nominal: -0.56}\n  zz: {nominal: 1}\n",
        ),
    );
    lincal(&["basis", &p(&s)]).fails(2, &["spec3.yaml:13", "zz"]);
}

#[test]
fn hostile_yaml_is_refused_at_its_place_quickly() {
    let dir = scratch("err-hostile-yaml");
    // 100 000 nested lists or mappings: refused at the nesting bound, not scanned whole.
    let s = write(&dir, "deep.yaml", &format!("x: {}", "[".repeat(100_000)));
    lincal(&["basis", &p(&s)]).fails(2, &["deep.yaml:1:", "invalid YAML (character"]);
    let s = write(
        &dir,
        "deep2.yaml",
        &format!("x: {}", "{a: ".repeat(100_000)),
    );
    lincal(&["basis", &p(&s)]).fails(2, &["deep2.yaml:1:", "deeper than 64"]);
    // An alias bomb stops at the node bound.
    let mut bomb = String::from("a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n");
    for i in 1..8 {
        let refs = vec![format!("*a{}", i - 1); 10].join(", ");
        bomb.push_str(&format!("a{i}: &a{i} [{refs}]\n"));
    }
    let s = write(&dir, "bomb.yaml", &bomb);
    lincal(&["basis", &p(&s)]).fails(2, &["bomb.yaml:", "100000 nodes"]);
    // A second document, named with its line and byte offset.
    let s = write(&dir, "two.yaml", &format!("{TWO_LINK}---\nname: y\n"));
    lincal(&["basis", &p(&s)]).fails(
        2,
        &["two.yaml:15:1", "character 286", "second YAML document"],
    );
    // A spec file is read up to its bound only (`/dev/zero` never ends).
    if std::path::Path::new("/dev/zero").exists() {
        lincal(&["basis", "/dev/zero"]).fails(2, &["/dev/zero", "longer than 1048576 bytes"]);
    }
    // Not UTF-8: the line and the byte offset of the first bad byte.
    let s = dir.join("utf8.yaml");
    std::fs::write(&s, b"name: x\ndim: \xff\n").unwrap();
    lincal(&["basis", &p(&s)]).fails(2, &["utf8.yaml:2", "offset 13"]);
}

#[test]
fn absurd_numbers_deep_expressions_and_long_rows_are_refused_with_their_place() {
    let dir = scratch("err-hostile-numbers");
    let bad = TWO_LINK
        .replace("a1: {nominal: 0.375}", "a1: {nominal: 1e160}")
        .replace("th1: {nominal: 0.0}", "th1: {nominal: 1e400}")
        .replace("home: th2}", "home: th2, d: 1e999999999}")
        .replace(
            "a2: {nominal: 0.425}",
            &format!(
                "a2: {{nominal: \"{}1{}\"}}",
                "(".repeat(5000),
                ")".repeat(5000)
            ),
        )
        .replace(
            "th2: {nominal: 0.0}",
            &format!("th2: {{nominal: \"{}1\"}}", "-".repeat(20_000)),
        );
    let s = write(&dir, "spec.yaml", &bad);
    let out = lincal(&["basis", &p(&s)]).fails(
        2,
        &[
            "spec.yaml:7:17: field `params.a1.nominal`: the value 1e160 is out of range",
            "field `params.th1.nominal`",
            "1e999999999",
            "field `params.a2.nominal`",
            "field `params.th2.nominal`",
        ],
    );
    // A bad value is echoed as a short prefix only.
    assert!(
        out.stderr.len() < 4000,
        "{} bytes of stderr",
        out.stderr.len()
    );

    // A truth file with the same expressions: refused, located, no stack overflow.
    let good = write(&dir, "good.yaml", TWO_LINK);
    let truth = write(
        &dir,
        "truth.yaml",
        &format!("a2: \"{}1{}\"\n", "(".repeat(5000), ")".repeat(5000)),
    );
    lincal(&["simulate", &p(&good), "--poses", "3", "--truth", &p(&truth)])
        .fails(2, &["truth.yaml:1", "a2"]);

    // A row longer than the line bound, and a file that never ends.
    let csv = write(
        &dir,
        "long.csv",
        &format!("q1,q2\n0.1,{}\n", "1".repeat(100_000)),
    );
    lincal(&["calibrate", &p(&good), &p(&csv)])
        .fails(2, &["long.csv:2", "longer than 65536 bytes"]);
    if std::path::Path::new("/dev/zero").exists() {
        lincal(&["calibrate", &p(&good), "/dev/zero"])
            .fails(2, &["/dev/zero:1", "longer than 65536 bytes"]);
    }
}

/// A planar arm of `n` joints with every length and home offset unknown, on an unknown line.
fn planar_all_unknown(n: usize) -> String {
    let mut s = format!("name: planar{n}\ndim: 2\njoints:\n");
    for i in 1..=n {
        s.push_str(&format!("  - {{type: revolute, a: a{i}, home: th{i}}}\n"));
    }
    s.push_str("params:\n");
    for i in 1..=n {
        s.push_str(&format!(
            "  a{i}: {{nominal: 0.3}}\n  th{i}: {{nominal: 0}}\n"
        ));
    }
    s + "  b1: {nominal: -1.8}\n  b2: {nominal: -0.5}\nconstraint:\n  line: {b: [b1, b2]}\n"
}

#[test]
fn basis_refuses_an_expansion_beyond_the_term_bound_before_it_is_built() {
    let dir = scratch("err-expansion-bound");
    // 20 joints would need about 4^20 terms: refused at the bound, in moments.
    let s = write(&dir, "planar20.yaml", &planar_all_unknown(20));
    lincal(&["basis".to_string(), p(&s)]).fails(
        1,
        &[
            "planar20.yaml",
            "spec `planar20`",
            "11184810 terms",
            "limit of 4000000",
            "--max-terms",
            "known: true",
        ],
    );
    // Simulation and fits do not need the expansion: the same spec runs.
    lincal(&["simulate", &p(&s), "--poses", "3"]).ok();
    // The bound is the user's: a small arm under a tiny bound is refused, under the default
    // it is not.
    let s = write(&dir, "planar4.yaml", &planar_all_unknown(4));
    lincal(&["basis", &p(&s), "--max-terms", "50"]).fails(1, &["limit of 50 terms"]);
    lincal(&["basis", &p(&s)]).ok();
}

/// A fit does not need the expansion: beyond the bound it starts from the nominals, says
/// why the linear method was not tried, and reports no `K`; asked for the linear method, it
/// fails naming the bound. Within the bound nothing changes.
#[test]
fn a_fit_beyond_the_term_bound_runs_in_parameter_space() {
    let dir = scratch("err-expansion-bound-fit");
    let s = write(&dir, "planar4.yaml", &planar_all_unknown(4));
    let sim = lincal(&["simulate", &p(&s), "--poses", "60", "--seed", "3"]).ok();
    let d = write(&dir, "data.csv", &sim.stdout);
    let small = ["--max-terms", "50"];
    let r = lincal(&[
        "calibrate",
        &p(&s),
        &p(&d),
        "--format",
        "json",
        small[0],
        small[1],
    ])
    .ok()
    .json();
    assert_eq!(r["start"], "nominal");
    assert!(r["basis_size"].is_null(), "{}", r["basis_size"]);
    assert!(r["basis"].as_array().is_some_and(Vec::is_empty));
    let warnings = r["warnings"].to_string();
    assert!(
        warnings.contains("beyond the expansion's bound"),
        "{warnings}"
    );
    assert!(
        r["residual_rms"].as_f64().is_some_and(|x| x < 1e-8),
        "{}",
        r["residual_rms"]
    );
    lincal(&[
        "calibrate",
        &p(&s),
        &p(&d),
        "--start",
        "linear",
        small[0],
        small[1],
    ])
    .fails(1, &["needs the basis", "--max-terms"]);
    let r = lincal(&["calibrate", &p(&s), &p(&d), "--format", "json"])
        .ok()
        .json();
    assert_eq!(r["start"], "linear");
    assert_eq!(r["basis_size"], 9);
}

#[test]
fn missing_files() {
    let dir = scratch("err-missing");
    lincal(&["basis", &p(&dir.join("none.yaml"))]).fails(2, &["none.yaml"]);
    let s = write(&dir, "spec.yaml", TWO_LINK);
    lincal(&["calibrate", &p(&s), &p(&dir.join("none.csv"))]).fails(2, &["none.csv"]);
}

#[test]
fn bad_csv_cells_and_columns() {
    let dir = scratch("err-csv");
    let s = write(&dir, "spec.yaml", TWO_LINK);
    let d = write(&dir, "bad.csv", "q1,q2\n0.1,0.2\n# a comment\n0.3,abc\n");
    lincal(&["calibrate", &p(&s), &p(&d)]).fails(2, &["bad.csv:4", "q2", "abc"]);
    let d = write(&dir, "nan.csv", "q1,q2\n0.1,0.2\nNaN,0.3\n");
    lincal(&["calibrate", &p(&s), &p(&d), "--format", "json"])
        .fails(2, &["nan.csv:3", "q1", "NaN"]);
    let d = write(&dir, "inf.csv", "q2,q1\n0.1,inf\n");
    lincal(&["calibrate", &p(&s), &p(&d)]).fails(2, &["inf.csv:2", "q1"]);
    let d = write(&dir, "extra.csv", "q1,q2,foo\n0.1,0.2,3\n");
    lincal(&["calibrate", &p(&s), &p(&d)]).fails(2, &["extra.csv:1", "foo"]);
    let d = write(&dir, "missing.csv", "q1\n0.1\n");
    lincal(&["calibrate", &p(&s), &p(&d)]).fails(2, &["missing.csv:1", "q2"]);
    let d = write(&dir, "short.csv", "q1,q2\n0.1,0.2\n0.3\n");
    lincal(&["calibrate", &p(&s), &p(&d)]).fails(2, &["short.csv:3"]);
}

#[test]
fn ignored_columns_and_comments_are_accepted() {
    let dir = scratch("ok-ignored");
    let s = p(&spec("line_planar4.yaml"));
    let sim = lincal(&["simulate", &s, "--poses", "30", "--seed", "3"]).ok();
    let mut text = String::from("# simulated\n");
    for (i, line) in sim.stdout.lines().enumerate() {
        if i == 0 {
            text.push_str(&format!("_note,{line}\n"));
        } else {
            text.push_str(&format!("{i},{line}\n"));
        }
    }
    let d = write(&dir, "data.csv", &text);
    let r = lincal(&["calibrate", &s, &p(&d), "--format", "json"])
        .ok()
        .json();
    assert_eq!(r["poses"], 30);
}

#[test]
fn bad_truth_file() {
    let dir = scratch("err-truth");
    let s = write(&dir, "spec.yaml", TWO_LINK);
    let t = write(&dir, "truth.yaml", "a1: 0.375\nqq: 2\n");
    lincal(&["simulate", &p(&s), "--poses", "3", "--truth", &p(&t)])
        .fails(2, &["truth.yaml:2", "qq"]);
    let t = write(&dir, "truth2.yaml", "a1: [0.375\n");
    lincal(&["simulate", &p(&s), "--poses", "3", "--truth", &p(&t)]).fails(2, &["truth2.yaml"]);
    let t = write(&dir, "truth3.yaml", "a1: 0.375\na2: .nan\n");
    lincal(&["simulate", &p(&s), "--poses", "3", "--truth", &p(&t)])
        .fails(2, &["truth3.yaml:2", "a2"]);
}

#[test]
fn usage_errors_exit_2() {
    let s = p(&spec("line_planar4.yaml"));
    lincal(&["simulate", &s]).fails(2, &["--poses"]);
    lincal(&["simulate", &s, "--poses", "-3"]).fails(2, &["--poses"]);
    lincal(&["simulate", &s, "--poses", "0"]).fails(2, &["--poses"]);
    lincal(&["simulate", &s, "--poses", "5", "--noise-track", "-1"]).fails(2, &["--noise-track"]);
    lincal(&["basis", &s, "--format", "xml"]).fails(2, &["xml"]);
    lincal(&["frobnicate"]).fails(2, &[]);
    lincal::<&str>(&[]).fails(2, &[]);
    let help = lincal(&["--help"]).ok();
    for cmd in ["basis", "calibrate", "simulate", "demo"] {
        assert!(help.stdout.contains(cmd), "help lacks {cmd}");
    }
}

#[test]
fn unreachable_constraint_is_degenerate() {
    let dir = scratch("err-unreachable");
    let s = write(&dir, "spec.yaml", TWO_LINK);
    let t = write(&dir, "truth.yaml", "b1: -0.1\nb2: -0.1\n");
    lincal(&["simulate", &p(&s), "--poses", "3", "--truth", &p(&t)]).fails(1, &["constraint"]);
    // Many poses fail as fast as few: the first attempts already show nothing lands.
    lincal(&["simulate", &p(&s), "--poses", "100000", "--truth", &p(&t)])
        .fails(1, &["first 500 attempts on constraint 0 all failed"]);
}

#[test]
fn absurd_and_negative_noise_is_refused() {
    let dir = scratch("err-noise");
    let s = write(&dir, "spec.yaml", TWO_LINK);
    lincal(&[
        "simulate",
        &p(&s),
        "--poses",
        "3",
        "--noise-encoder",
        "1e308",
    ])
    .fails(2, &["--noise-encoder", "from 0 to 1"]);
    lincal(&["simulate", &p(&s), "--poses", "3", "--noise-track=-1e-5"])
        .fails(2, &["--noise-track", "negative"]);
}

#[test]
fn simulate_writes_every_row_of_a_long_run() {
    // Rows are written as they are made (memory flat in --poses, see BENCHMARKS.md).
    let dir = scratch("sim-stream");
    let s = write(&dir, "spec.yaml", TWO_LINK);
    let out = lincal(&["simulate", &p(&s), "--poses", "20000", "--seed", "3"]).ok();
    assert_eq!(out.stdout.lines().count(), 20_001);
    assert!(out.stdout.starts_with("q1,q2\n"));
}

/// A two-link spec and 40 simulated poses on its line, in a fresh scratch directory.
fn two_link_data(name: &str) -> (std::path::PathBuf, String, std::path::PathBuf) {
    let dir = scratch(name);
    let s = write(&dir, "spec.yaml", TWO_LINK);
    let sim = lincal(&["simulate", &p(&s), "--poses", "40", "--seed", "9"]).ok();
    (dir, sim.stdout, s)
}

#[test]
fn degenerate_fewer_poses_than_k() {
    let (dir, csv, s) = two_link_data("err-degenerate-few");
    let few: String = csv.lines().take(4).map(|l| format!("{l}\n")).collect();
    let d = write(&dir, "few.csv", &few);
    lincal(&["calibrate", &p(&s), &p(&d), "--format", "json"])
        .fails(1, &["3 poses", "4 free parameters", "at least 5 poses"]);
    let d = write(&dir, "empty.csv", "q1,q2\n");
    let r = lincal(&["calibrate", &p(&s), &p(&d)]);
    assert!(r.code == 1 || r.code == 2, "{}", r.stderr);
    assert!(!r.stderr.is_empty() && !r.stderr.contains("panicked"));
}

#[test]
fn degenerate_frozen_joint() {
    let (dir, csv, s) = two_link_data("err-degenerate-frozen");
    // The recorded q2 never moves (a broken encoder): the poses cannot separate the links.
    let mut frozen = String::from("q1,q2\n");
    for line in csv.lines().skip(1) {
        let q1 = line.split(',').next().unwrap_or("0");
        frozen.push_str(&format!("{q1},0.7\n"));
    }
    let d = write(&dir, "frozen.csv", &frozen);
    lincal(&["calibrate", &p(&s), &p(&d)]).fails(1, &["q2"]);
    lincal(&["calibrate", &p(&s), &p(&d), "--refine", "--format", "json"]).fails(1, &["q2"]);
}

#[test]
fn degenerate_identical_poses() {
    let (dir, csv, s) = two_link_data("err-degenerate-same");
    let first = csv.lines().nth(1).unwrap_or("0.3,0.5");
    let same = format!("q1,q2\n{}", format!("{first}\n").repeat(30));
    let d = write(&dir, "same.csv", &same);
    lincal(&["calibrate", &p(&s), &p(&d)]).fails(1, &["same"]);
    lincal(&["calibrate", &p(&s), &p(&d), "--refine"]).fails(1, &["same"]);
}

#[test]
fn a_bad_row_is_named_in_the_warnings() {
    // Joint limits on the second joint; one row of the data breaks them (a corrupted reading):
    // calibration still runs, and the warnings name that pose, its line and the limit.
    let dir = scratch("warn-bad-row");
    let limited = TWO_LINK.replace(
        "  - {type: revolute, a: a2, home: th2}",
        "  - {type: revolute, a: a2, home: th2, limits: [-2.8, 2.8]}",
    );
    let s = write(&dir, "spec.yaml", &limited);
    let sim = lincal(&["simulate", &p(&s), "--poses", "60", "--seed", "4"]).ok();
    let mut lines: Vec<String> = sim.stdout.lines().map(str::to_string).collect();
    let q1 = lines[3].split(',').next().unwrap_or("0.1").to_string();
    lines[3] = format!("{q1},3.1");
    let d = write(&dir, "data.csv", &(lines.join("\n") + "\n"));
    let r = lincal(&["calibrate", &p(&s), &p(&d), "--format", "json"]).ok();
    let warnings = r.json()["warnings"].to_string();
    assert!(warnings.contains("pose 2 (line 4): q2 = 3.1"), "{warnings}");
    assert!(
        warnings.contains("the farthest pose is 2, line 4"),
        "{warnings}"
    );
}

/// Mutated specs and CSVs through the binary: exit 0, 1 or 2 only (never a signal, never
/// 101 or 134), every failure with a message, each run within a time budget.
#[test]
fn mutated_inputs_through_the_binary_end_with_a_promised_status() {
    use rand::{Rng, SeedableRng};
    const CASES: usize = 300;
    const TOKENS: &[&str] = &[
        ":",
        "[",
        "{",
        "- ",
        "1e400",
        "((((1))))",
        "ä",
        "\t",
        ";",
        "1,5",
        "nan",
        "known: true",
        "---\n",
        "*a",
        "!t ",
        "#",
    ];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0xb1a);
    let dir = scratch("fuzz-binary");
    let base = std::fs::read_to_string(spec("line_planar4.yaml")).unwrap();
    let good = write(&dir, "good.yaml", &base);
    let csv = lincal(&[
        "simulate",
        &p(&good),
        "--poses",
        "40",
        "--noise-track",
        "1e-5",
    ])
    .ok()
    .stdout;
    let mutate = |text: &str, rng: &mut rand_chacha::ChaCha8Rng| {
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let i = rng.gen_range(0..lines.len());
        match rng.gen_range(0..3) {
            0 => {
                lines.remove(i);
            }
            1 => {
                let l = lines[i].clone();
                lines.insert(i, l);
            }
            _ => {
                let t = TOKENS[rng.gen_range(0..TOKENS.len())];
                let cuts: Vec<usize> = lines[i]
                    .char_indices()
                    .map(|(k, _)| k)
                    .chain([lines[i].len()])
                    .collect();
                let at = cuts[rng.gen_range(0..cuts.len())];
                lines[i].insert_str(at, t);
            }
        }
        lines.join("\n") + "\n"
    };
    for case in 0..CASES {
        let (s, d) = if case % 2 == 0 {
            (write(&dir, "m.yaml", &mutate(&base, &mut rng)), None)
        } else {
            (
                good.clone(),
                Some(write(&dir, "m.csv", &mutate(&csv, &mut rng))),
            )
        };
        let t = std::time::Instant::now();
        let run = match &d {
            None => lincal(&["basis", &p(&s)]),
            Some(d) => lincal(&["calibrate", &p(&s), &p(d), "--format", "json"]),
        };
        let took = t.elapsed();
        assert!(
            [0, 1, 2].contains(&run.code),
            "case {case}: exit {} ({})",
            run.code,
            run.stderr
        );
        assert!(
            run.code == 0 || run.stderr.starts_with("lincal: "),
            "case {case}: {}",
            run.stderr
        );
        assert!(
            took < std::time::Duration::from_secs(5),
            "case {case}: {took:?}"
        );
    }
}

#[test]
fn messages_say_what_the_file_probably_meant() {
    let dir = scratch("err-hints");
    let s = spec("line_planar4.yaml");
    let csv = lincal(&["simulate", &p(&s), "--poses", "30", "--seed", "2"])
        .ok()
        .stdout;
    let semi = write(&dir, "semi.csv", &csv.replace(',', ";"));
    lincal(&["calibrate", &p(&s), &p(&semi)]).fails(2, &["semi.csv:1", "separated by semicolons"]);
    let tabs = write(&dir, "tabs.csv", &csv.replace(',', "\t"));
    lincal(&["calibrate", &p(&s), &p(&tabs)]).fails(2, &["tabs.csv:1", "separated by tabs"]);
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    lines[2] = lines[2].replacen('.', ",", 1);
    let comma = write(&dir, "comma.csv", &(lines.join("\n") + "\n"));
    lincal(&["calibrate", &p(&s), &p(&comma)]).fails(2, &["comma.csv:3", "decimal comma"]);
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    let rest = lines[3].split_once(',').unwrap().1.to_string();
    lines[3] = format!("1e300,{rest}");
    let huge = write(&dir, "huge.csv", &(lines.join("\n") + "\n"));
    lincal(&["calibrate", &p(&s), &p(&huge)])
        .fails(2, &["huge.csv:4", "field `q1`", "out of range"]);
    // Degrees: refused by default (beyond a full turn and the limits [-2.8, 2.8]), naming the
    // first such reading; a warning with `--angles rad` (the readings are legal numbers).
    let deg: Vec<String> = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                l.to_string()
            } else {
                l.split(',')
                    .map(|x| format!("{}", x.parse::<f64>().unwrap().to_degrees()))
                    .collect::<Vec<_>>()
                    .join(",")
            }
        })
        .collect();
    let first = deg[1]
        .split(',')
        .position(|c| c.parse::<f64>().unwrap().abs() > std::f64::consts::TAU)
        .expect("a reading of line 2 beyond a full turn and the limits");
    let deg = write(&dir, "deg.csv", &(deg.join("\n") + "\n"));
    lincal(&["calibrate", &p(&s), &p(&deg)]).fails(
        2,
        &[
            "deg.csv:2",
            &format!("field `q{}`", first + 1),
            "these look like degrees: pass --angles deg to convert, or --angles rad",
        ],
    );
    let out = lincal(&[
        "calibrate",
        &p(&s),
        &p(&deg),
        "--format",
        "json",
        "--start",
        "nominal",
        "--angles",
        "rad",
    ]);
    assert!(
        out.stdout.contains("beyond a full turn") || out.stderr.contains("beyond a full turn"),
        "{}{}",
        out.stdout,
        out.stderr
    );
    // A negative radius is refused where it is written, as a number or as a nominal.
    let sphere = std::fs::read_to_string(spec("sphere_mdh.yaml")).unwrap();
    assert!(sphere.contains("radius: r}"));
    let neg = write(
        &dir,
        "neg.yaml",
        &sphere
            .replace("radius: r}", "radius: -0.1}")
            .replace("  r: {nominal", "  rr: {nominal"),
    );
    lincal(&["basis", &p(&neg)]).fails(2, &["neg.yaml:22", "radius is negative"]);
    let r_line = sphere
        .lines()
        .find(|l| l.starts_with("  r: {nominal"))
        .unwrap();
    let neg = write(
        &dir,
        "neg2.yaml",
        &sphere.replace(r_line, "  r: {nominal: -0.2}"),
    );
    lincal(&["basis", &p(&neg)]).fails(2, &["neg2.yaml:22", "radius is negative"]);
}

#[test]
fn a_known_zero_b_describes_no_plane_and_is_refused() {
    let dir = scratch("err-zero-b");
    let line = TWO_LINK.replace("line: {b: [b1, b2]}", "line: {b: [0, 0]}");
    let line = line.replace("  b1: {nominal: -1.79}\n  b2: {nominal: -0.56}\n", "");
    let s = write(&dir, "line.yaml", &line);
    lincal(&["basis", &p(&s)]).fails(2, &["line.yaml", "constraint.line.b", "zero"]);
    lincal(&["simulate", &p(&s), "--poses", "3"]).fails(2, &["constraint.line.b"]);
    // Known parameters whose nominal is 0 are refused the same way.
    let known = TWO_LINK
        .replace("b1: {nominal: -1.79}", "b1: {nominal: 0, known: true}")
        .replace("b2: {nominal: -0.56}", "b2: {nominal: 0, known: true}");
    let s = write(&dir, "known.yaml", &known);
    lincal(&["basis", &p(&s)]).fails(2, &["known.yaml", "constraint.line.b"]);
}

/// A spec with nothing to estimate (every parameter known, or only numbers in the slots) is
/// not an error: every start reports the nominal model's residuals, as `--start nominal`
/// does, without a panic.
#[test]
fn a_spec_with_nothing_to_estimate_reports_its_residuals() {
    let dir = scratch("nothing_to_estimate");
    let known = write(
        &dir,
        "known.yaml",
        "name: allknown\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  - {type: \
         revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.375, known: true}\n  a2: \
         {nominal: 0.425, known: true}\n  th1: {nominal: 0.0, known: true}\n  th2: {nominal: \
         0.0, known: true}\n  b1: {nominal: -1.79, known: true}\n  b2: {nominal: -0.56, known: \
         true}\nconstraint:\n  line: {b: [b1, b2]}\n",
    );
    let numbers = write(
        &dir,
        "numbers.yaml",
        "name: allnumbers\ndim: 2\njoints:\n  - {type: revolute, a: 0.375, home: 0}\n  - {type: \
         revolute, a: 0.425, home: 0}\nparams: {}\nconstraint:\n  line: {b: [-1.79, -0.56]}\n",
    );
    let data = write(
        &dir,
        "data.csv",
        "q1,q2\n0.1,0.5\n0.4,-0.3\n-0.2,1.1\n0.9,0.2\n-0.7,-0.6\n0.3,0.8\n",
    );
    for spec in [&known, &numbers] {
        for start in ["auto", "linear", "nominal"] {
            let r = lincal(&[
                "calibrate",
                &p(spec),
                &p(&data),
                "--start",
                start,
                "--refine",
                "--format",
                "json",
            ])
            .ok()
            .json();
            let rms = r["residual_rms"].as_f64().expect("residual_rms");
            assert!(rms.is_finite() && rms > 0.0, "{start}: {r}");
        }
    }
}
