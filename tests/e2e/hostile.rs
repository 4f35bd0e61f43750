//! Hostile inputs (issue 25, classes 3-9): URDFs nested deep, with duplicate or injected
//! names and absurd numbers; data from a FIFO with a report; a write cut by the file-size
//! limit; terminal escapes, bare CRs, quoted fields and floods of errors; predictions
//! beyond range. Each ends with exit 0, 1 or 2 and a message naming the place, nothing
//! overwritten and no injected markup.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::{lincal, scratch, spec, write};

fn p(path: &Path) -> String {
    path.display().to_string()
}

/// The 7-joint test URDF's text.
fn iiwa() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/iiwa14.urdf");
    std::fs::read_to_string(path).expect("the test URDF")
}

/// `text` written as `name` in `dir`, imported from `world` to `iiwa_link_ee`.
fn import(dir: &Path, name: &str, text: &str) -> crate::util::Run {
    let u = write(dir, name, text);
    lincal(&["import", &p(&u), "--base", "world", "--tip", "iiwa_link_ee"])
}

#[test]
fn hostile_urdfs_are_refused_by_name_and_line_or_read_safely() {
    let dir = scratch("hostile-urdf");
    let t = iiwa();
    let n = 20_000;
    let deep = t.replace(
        "</robot>",
        &format!("{}{}</robot>", "<x>".repeat(n), "</x>".repeat(n)),
    );
    import(&dir, "deep.urdf", &deep).fails(2, &["deep.urdf:", "nested more than 256"]);
    let dup = t.replacen("name=\"iiwa_joint_2\"", "name=\"iiwa_joint_1\"", 1);
    import(&dir, "dup.urdf", &dup).fails(
        2,
        &[
            "dup.urdf:20",
            "a second joint named `iiwa_joint_1`",
            "line 12",
        ],
    );
    let newline = t.replace("\"iiwa_joint_3\"", "\"j&#10;3\"");
    import(&dir, "nl.urdf", &newline).fails(2, &["nl.urdf:28", "control character U+000A"]);
    let far = t.replace("xyz=\"0 0 0.1575\"", "xyz=\"0 0 1e308\"");
    import(&dir, "far.urdf", &far).fails(2, &["far.urdf:12", "iiwa_joint_1`.origin", "beyond"]);
    let huge = t.replacen("<axis xyz=\"0 0 1\"/>", "<axis xyz=\"0 0 1e200\"/>", 1);
    let wide = t.replacen("<axis xyz=\"0 0 1\"/>", "<axis xyz=\"1e308 1e308 0\"/>", 1);
    import(&dir, "huge.urdf", &huge).ok();
    import(&dir, "wide.urdf", &wide).ok();
    let u = write(&dir, "plain.urdf", &t);
    lincal(&[
        "import",
        &p(&u),
        "--base",
        "world",
        "--tip",
        "iiwa_link_ee",
        "--tool",
        "1e9,1e9,1e9",
    ])
    .fails(2, &["--tool", "beyond"]);
}

#[test]
fn names_and_paths_written_into_a_urdf_cannot_inject_markup() {
    let dir = scratch("hostile-names");
    let evil = "j1--&gt;&lt;!DOCTYPE robot [&lt;!ENTITY xxe SYSTEM &quot;file:///etc/passwd&quot;&gt;]&gt;&lt;!--";
    let t = iiwa().replace("\"iiwa_joint_1\"", &format!("\"{evil}\""));
    let u = write(&dir, "a--b-.urdf", &t);
    let imported = lincal(&["import", &p(&u), "--base", "world", "--tip", "iiwa_link_ee"]).ok();
    let s = write(&dir, "spec.yaml", &imported.stdout);
    let sim = lincal(&["simulate", &p(&s), "--poses", "40", "--seed", "5"]).ok();
    let d = write(&dir, "data.csv", &sim.stdout);
    let out = dir.join("out.urdf");
    lincal(&["calibrate", &p(&s), &p(&d), "--write-urdf", &p(&out)]).ok();
    let written = std::fs::read_to_string(&out).expect("the written URDF");
    let doc = roxmltree::Document::parse(&written).expect("the written URDF is well formed");
    // The name may be quoted in a comment, never outside one.
    let mut outside = String::new();
    let mut rest = written.as_str();
    while let Some(i) = rest.find("<!--") {
        outside.push_str(&rest[..i]);
        let end = rest[i..].find("-->").expect("every comment closes");
        rest = &rest[i + end + 3..];
    }
    outside.push_str(rest);
    assert!(
        !outside.contains("<!DOCTYPE"),
        "a DOCTYPE got out:\n{written}"
    );
    let comments: Vec<&str> = doc
        .descendants()
        .filter(|n| n.is_comment())
        .filter_map(|n| n.text())
        .collect();
    assert!(
        comments.iter().any(|c| c.contains("Written by lincal")),
        "{comments:?}"
    );
}

/// A URDF that starts with a UTF-8 byte-order mark (with and without an XML declaration):
/// the written file keeps the mark, every edit lands in place, and a conforming parser reads
/// it, the declaration first and the comment after it.
#[test]
fn a_urdf_with_a_byte_order_mark_is_written_in_place() {
    let dir = scratch("hostile-bom");
    for (name, text) in [
        ("decl.urdf", format!("\u{feff}{}", iiwa())),
        (
            "nodecl.urdf",
            format!("\u{feff}{}", strip_declaration(&iiwa())),
        ),
    ] {
        let u = write(&dir, name, &text);
        let imported = lincal(&["import", &p(&u), "--base", "world", "--tip", "iiwa_link_ee"]).ok();
        let s = write(&dir, &format!("{name}.yaml"), &imported.stdout);
        let sim = lincal(&["simulate", &p(&s), "--poses", "40", "--seed", "5"]).ok();
        let d = write(&dir, &format!("{name}.csv"), &sim.stdout);
        let out = dir.join(format!("out-{name}"));
        lincal(&["calibrate", &p(&s), &p(&d), "--write-urdf", &p(&out)]).ok();
        let written = std::fs::read_to_string(&out).expect("the written URDF");
        let body = written
            .strip_prefix('\u{feff}')
            .unwrap_or_else(|| panic!("{name}: the byte-order mark is kept"));
        let doc = roxmltree::Document::parse(body)
            .unwrap_or_else(|e| panic!("{name}: not well-formed: {e}\n{written}"));
        assert_eq!(doc.root_element().tag_name().name(), "robot");
        assert!(
            !body.contains("\"/>\"/>"),
            "{name}: debris of a misplaced edit"
        );
        if name == "decl.urdf" {
            assert!(body.starts_with("<?xml"), "{name}: the declaration first");
        }
        // The joints' origins were rewritten: the imported spec reads the new file back.
        assert!(body.contains("Written by lincal"));
        assert_eq!(
            doc.descendants()
                .filter(|n| n.has_tag_name("joint"))
                .count(),
            roxmltree::Document::parse(strip_declaration(&iiwa()).trim_start())
                .unwrap()
                .descendants()
                .filter(|n| n.has_tag_name("joint"))
                .count()
        );
    }
}

/// The text without its `<?xml …?>` declaration.
fn strip_declaration(t: &str) -> String {
    match (t.find("<?xml"), t.find("?>")) {
        (Some(a), Some(b)) if a < b => format!("{}{}", &t[..a], &t[b + 2..]),
        _ => t.to_string(),
    }
}

/// `--columns` with 40 000 bad names: the error shows the first problems and counts the rest,
/// kilobytes rather than megabytes.
#[test]
fn an_error_about_many_columns_is_capped() {
    let dir = scratch("hostile-columns");
    let data = write(&dir, "d.csv", "0.1,0.2\n");
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("lincal-models/specs/adept_one.yaml");
    let cols = vec!["q9"; 40_000].join(",");
    let run = lincal(&[
        "calibrate",
        &p(&spec),
        &p(&data),
        "--no-header",
        "--columns",
        &cols,
    ]);
    let run = run.fails(2, &["--columns", "more problems"]);
    assert!(
        run.stderr.len() < 16_384,
        "{} bytes of stderr",
        run.stderr.len()
    );
}

/// `select --pool 200000 --draws 20` under a 2 GiB address-space limit: the plan's budget
/// counts what the limit leaves, so the request is refused by name (exit 2), never an abort.
#[test]
fn select_under_an_address_space_limit_is_refused_not_aborted() {
    if Command::new("prlimit").arg("--version").output().is_err() {
        eprintln!("no prlimit: skipped");
        return;
    }
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("lincal-models/specs/ur5_tracker.yaml");
    let out = Command::new("prlimit")
        .arg(format!("--as={}", 2u64 << 30))
        .arg(env!("CARGO_BIN_EXE_lincal"))
        .args([
            "select",
            &p(&spec),
            "-n",
            "40",
            "--pool",
            "200000",
            "--draws",
            "20",
        ])
        .env("LINCAL_CACHE", "off")
        .output()
        .expect("prlimit runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr:\n{stderr}");
    assert!(stderr.contains("--pool"), "{stderr}");
}

/// A joint's `<origin …></origin>` (start and end tags, legal XML) is rewritten whole by
/// `--write-urdf`; a joint with two `<origin>` elements is refused, naming both lines.
#[test]
fn origins_in_start_and_end_tags_and_twice() {
    let dir = scratch("hostile-origins");
    let text = iiwa().replace(
        "<origin xyz=\"0 0 0.2025\" rpy=\"1.5707963267948966 0 3.141592653589793\"/>",
        "<origin xyz=\"0 0 0.2025\" rpy=\"1.5707963267948966 0 3.141592653589793\"></origin>",
    );
    assert!(text.contains("></origin>"));
    let u = write(&dir, "tags.urdf", &text);
    let imported = lincal(&["import", &p(&u), "--base", "world", "--tip", "iiwa_link_ee"]).ok();
    let s = write(&dir, "tags.yaml", &imported.stdout);
    let sim = lincal(&["simulate", &p(&s), "--poses", "40", "--seed", "5"]).ok();
    let d = write(&dir, "tags.csv", &sim.stdout);
    let out = dir.join("out.urdf");
    lincal(&["calibrate", &p(&s), &p(&d), "--write-urdf", &p(&out)]).ok();
    let written = std::fs::read_to_string(&out).expect("the written URDF");
    roxmltree::Document::parse(&written).expect("well-formed");
    assert!(
        !written.contains("></origin>"),
        "the origin was rewritten whole"
    );
    // Twice in one joint.
    let twice = iiwa().replacen(
        "<origin xyz=\"0 0 0.1575\" rpy=\"0 0 0\"/>",
        "<origin xyz=\"0 0 0.1575\" rpy=\"0 0 0\"/>\n    <origin xyz=\"0 0 0.2\"/>",
        1,
    );
    let u = write(&dir, "twice.urdf", &twice);
    lincal(&["import", &p(&u), "--base", "world", "--tip", "iiwa_link_ee"])
        .fails(2, &["second `<origin>`", "line 16", "line 15"]);
}

/// Hand-edited result files for `predict` (and `evaluate`, `compensate`, which read them the
/// same way): a parameter given twice, an edited known parameter and a value beyond the
/// spec's own bound are refused by name.
#[test]
fn edited_result_files_are_read_with_the_specs_rules() {
    let dir = scratch("hostile-results");
    let s = write(
        &dir,
        "spec.yaml",
        "name: two\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
         - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.375}\n  \
         th1: {nominal: 0}\n  a2: {nominal: 0.425, known: true}\n  th2: {nominal: 0}\n  \
         b1: {nominal: -1.8}\n  b2: {nominal: -0.5}\nconstraint:\n  line: {b: [b1, b2]}\n",
    );
    let q = write(&dir, "q.csv", "q1,q2\n0.1,0.2\n");
    let result = |params: &str| format!("{{\"name\": \"two\", \"params\": {{{params}}}}}");
    let base = "\"a1\": {\"value\": 0.38}, \"th1\": {\"value\": 0.0}, \
                \"th2\": {\"value\": 0.01}, \"b1\": {\"value\": -1.8}, \"b2\": {\"value\": -0.5}";
    // The plain file predicts.
    let ok = write(&dir, "ok.json", &result(base));
    lincal(&["predict", &p(&s), "--params", &p(&ok), &p(&q)]).ok();
    // The known parameter at its value is fine; edited, refused.
    let same = write(
        &dir,
        "same.json",
        &result(&format!("{base}, \"a2\": {{\"value\": 0.425}}")),
    );
    lincal(&["predict", &p(&s), "--params", &p(&same), &p(&q)]).ok();
    let edited = write(
        &dir,
        "edited.json",
        &result(&format!("{base}, \"a2\": {{\"value\": 0.5}}")),
    );
    lincal(&["predict", &p(&s), "--params", &p(&edited), &p(&q)])
        .fails(2, &["params.a2.value", "known"]);
    // Twice.
    let twice = write(
        &dir,
        "twice.json",
        &result(&format!("{base}, \"a1\": {{\"value\": 0.9}}")),
    );
    lincal(&["predict", &p(&s), "--params", &p(&twice), &p(&q)]).fails(2, &["`a1` is given twice"]);
    // Beyond the spec's bound.
    let huge = write(
        &dir,
        "huge.json",
        &result(&base.replace("\"th2\": {\"value\": 0.01}", "\"th2\": {\"value\": 1e300}")),
    );
    lincal(&["predict", &p(&s), "--params", &p(&huge), &p(&q)])
        .fails(2, &["params.th2.value", "1e9"]);
}

/// `mkfifo PATH`, then a thread writing `bytes` into it.
fn fifo(path: &Path, bytes: Vec<u8>) -> std::thread::JoinHandle<()> {
    let made = Command::new("mkfifo").arg(path).status().expect("mkfifo");
    assert!(made.success());
    let path = path.to_path_buf();
    std::thread::spawn(move || {
        // Opening blocks until lincal opens the other end.
        let _ = std::fs::write(path, bytes);
    })
}

#[test]
fn a_fifo_input_with_a_report_is_read_once_and_hashed_as_read() {
    let dir = scratch("hostile-fifo");
    let s = spec("line_planar4.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "60", "--seed", "2"]).ok();
    let f = dir.join("data.fifo");
    let writer = fifo(&f, sim.stdout.clone().into_bytes());
    let report = dir.join("r.html");
    lincal(&["calibrate", &p(&s), &p(&f), "--report", &p(&report)]).ok();
    writer.join().expect("the writer");
    let html = std::fs::read_to_string(&report).expect("the report");
    let sha = Command::new("sha256sum")
        .arg(write(&dir, "copy.csv", &sim.stdout))
        .output()
        .expect("sha256sum");
    let sha = String::from_utf8_lossy(&sha.stdout);
    let sha = sha.split_whitespace().next().expect("a hash");
    assert!(
        html.contains(sha),
        "the report lacks the fitted bytes' hash {sha}"
    );
    assert!(
        html.contains(&format!(">{}<", sim.stdout.len())),
        "the size"
    );
}

#[cfg(target_os = "linux")]
#[test]
fn a_write_cut_by_the_file_size_limit_leaves_the_previous_file_whole() {
    let (dir, s, d) = {
        let dir = scratch("hostile-fsize");
        let s = spec("line_planar4.yaml");
        let sim = lincal(&["simulate", &p(&s), "--poses", "60", "--seed", "2"]).ok();
        let d = write(&dir, "data.csv", &sim.stdout);
        (dir, s, d)
    };
    let report = write(&dir, "r.html", "the previous report");
    // 4 KiB: the data are read, the report (tens of kilobytes) cannot be written.
    let cmd = format!(
        "ulimit -f 4; exec '{}' calibrate '{}' '{}' --report '{}'",
        env!("CARGO_BIN_EXE_lincal"),
        p(&s),
        p(&d),
        p(&report)
    );
    let out = Command::new("sh")
        .arg("-c")
        .arg(cmd)
        .env("LINCAL_CACHE", "off")
        .output()
        .expect("sh");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr:\n{stderr}");
    assert!(stderr.contains("cannot write the report"), "{stderr}");
    assert_eq!(
        std::fs::read_to_string(&report).expect("r.html"),
        "the previous report"
    );
    let left: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

#[test]
fn messages_escape_control_characters_and_cap_their_count() {
    let dir = scratch("hostile-messages");
    let s = spec("point_planar3.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "20", "--seed", "1"]).ok();
    let mut rows: Vec<String> = sim.stdout.lines().map(str::to_string).collect();
    rows[3] = "1.0,\u{1b}]0;pwned\u{7},2.0".to_string();
    let d = write(&dir, "osc.csv", &(rows.join("\n") + "\n"));
    let run = lincal(&["calibrate", &p(&s), &p(&d)]).fails(2, &["osc.csv:4", "\\u{1b}]0;pwned"]);
    assert!(!run.stderr.contains('\u{1b}') && !run.stderr.contains('\u{7}'));
    let names: Vec<String> = (0..8000).map(|i| format!("u{i}")).collect();
    let header = format!("q1,q2,q3,{}", names.join(","));
    let d = write(
        &dir,
        "wide.csv",
        &format!("{header}\n0,0,0{}\n", ",".repeat(8000)),
    );
    let run =
        lincal(&["calibrate", &p(&s), &p(&d)]).fails(2, &["unknown column `u0`", "7980 more"]);
    assert!(
        run.stderr.len() < 4096,
        "{} bytes of errors",
        run.stderr.len()
    );
}

#[test]
fn bare_cr_lines_and_quoted_fields_read_as_the_same_data() {
    let dir = scratch("hostile-csv");
    let s = spec("point_planar3.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "30", "--seed", "4"]).ok();
    let lf = write(&dir, "lf.csv", &sim.stdout);
    let cr = write(&dir, "cr.csv", &sim.stdout.replace('\n', "\r"));
    let quoted: Vec<String> = sim
        .stdout
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                format!("{l},_note")
            } else {
                format!("{l},\"left, \"\"right\"\"\"")
            }
        })
        .collect();
    let quoted = write(&dir, "quoted.csv", &(quoted.join("\n") + "\n"));
    let fit = |d: &Path| {
        lincal(&["calibrate", &p(&s), &p(d), "--format", "json"])
            .ok()
            .json()
    };
    let base = fit(&lf);
    assert_eq!(fit(&cr)["params"], base["params"]);
    assert_eq!(fit(&quoted)["params"], base["params"]);
    let open = write(&dir, "open.csv", "q1,q2,q3,_note\n0,1,2,\"never closed\n");
    lincal(&["calibrate", &p(&s), &p(&open)]).fails(2, &["open.csv:2", "not closed"]);
}

#[test]
fn predictions_beyond_range_are_an_error_not_inf() {
    let dir = scratch("hostile-predict");
    let s = spec("point_planar3.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "10", "--seed", "1"]).ok();
    let d = write(&dir, "d.csv", &sim.stdout);
    let result = lincal(&["calibrate", &p(&s), &p(&d), "--format", "json"]).ok();
    let mut v = result.json();
    // A value beyond the spec's own bound is refused at the result file.
    v["params"]["a1"]["value"] = serde_json::json!(1e308);
    let r = write(&dir, "r.json", &v.to_string());
    let run = lincal(&["predict", &p(&s), "--params", &p(&r), &p(&d)])
        .fails(2, &["r.json", "params.a1.value", "beyond"]);
    assert!(run.stdout.is_empty(), "partial output:\n{}", run.stdout);
    // Values within it whose tips pass 1e9 are refused at the first such pose.
    for a in ["a1", "a2", "a3"] {
        v["params"][a]["value"] = serde_json::json!(9e8);
    }
    let r = write(&dir, "r2.json", &v.to_string());
    let run = lincal(&["predict", &p(&s), "--params", &p(&r), &p(&d)])
        .fails(2, &["d.csv:", "--params", "beyond"]);
    assert!(run.stdout.is_empty(), "partial output:\n{}", run.stdout);
    let big = write(&dir, "big.json", &" ".repeat(17 << 20));
    lincal(&["predict", &p(&s), "--params", &p(&big), &p(&d)])
        .fails(2, &["big.json", "longer than"]);
}

/// Hostile sizes under a 2 GiB address-space limit (issue 50): each ends with a status of its
/// own (0, 1 or 2), never a signal (an abort on a refused allocation, the OOM killer).
#[test]
fn big_requests_under_an_address_space_limit_end_with_a_status() {
    if Command::new("prlimit").arg("--version").output().is_err() {
        eprintln!("no prlimit: skipped");
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let pose = root.join("bench/limits/arm7_all_unknown_pose.yaml");
    let ur5 = root.join("lincal-models/specs/ur5_tracker.yaml");
    // The iiwa's URDF-native rows (six unknowns per joint origin): an expansion whose terms
    // outgrow the limit while a product is being formed, not before.
    let dir = scratch("address-space");
    let iiwa = lincal(&[
        "import",
        &p(&root.join("tests/urdf/iiwa14.urdf")),
        "--base",
        "iiwa_link_0",
        "--tip",
        "iiwa_link_ee",
        "--convention",
        "urdf",
    ])
    .ok();
    let iiwa = write(&dir, "iiwa_urdf.yaml", &iiwa.stdout);
    let big = |spec: &Path, terms: &str| -> Vec<String> {
        vec!["basis".into(), p(spec), "--max-terms".into(), terms.into()]
    };
    // A 9-joint measured pose with every DH and tool-frame entry unknown at the default
    // bound (the attack's case: it aborted under 3 and 4 GB when the guard counted 600
    // bytes a term).
    let arm9 = root.join("tests/large/arm9_all_unknown_pose_frame.yaml");
    // A basis that is not a set of grid monomials (parallel axes): the expansion itself runs
    // into the limit (the models above are full grids, proven without it since session 31).
    let parallel = root.join("bench/limits/arm6_parallel_quadric.yaml");
    let small: Vec<(u64, Vec<String>)> = vec![
        (400_000_000, big(&pose, "10000000")),
        (400_000_000, big(&parallel, "100000000")),
        (2 << 30, big(&iiwa, "20000000")),
        (3 << 30, vec!["basis".into(), p(&arm9)]),
    ];
    let cases: Vec<Vec<String>> = vec![
        // Item 8: a 7-joint all-unknown measured-pose model's basis, the expansion's bound
        // raised twentyfold (its `c(p)` alone would be 378 MB of text).
        vec![
            "basis".into(),
            p(&pose),
            "--max-terms".into(),
            "10000000".into(),
        ],
        vec![
            "basis".into(),
            p(&pose),
            "--max-terms".into(),
            "10000000".into(),
            "--format".into(),
            "json".into(),
        ],
        // Item 7's class: a design larger than the limit leaves.
        vec![
            "select".into(),
            p(&ur5),
            "-n".into(),
            "40".into(),
            "--pool".into(),
            "1000000".into(),
            "--draws".into(),
            "100".into(),
        ],
    ];
    let limited = cases.into_iter().map(|c| (2u64 << 30, c)).chain(small);
    for (limit, args) in limited {
        let out = Command::new("prlimit")
            .arg(format!("--as={limit}"))
            .arg(env!("CARGO_BIN_EXE_lincal"))
            .args(&args)
            .env("LINCAL_CACHE", "off")
            .output()
            .expect("prlimit runs");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            matches!(out.status.code(), Some(0..=2)),
            "lincal {}: {:?}\n{}",
            args.join(" "),
            out.status,
            &stderr[..stderr.len().min(2000)]
        );
    }
}

/// A chain whose URDF origin sits at the reader's bound (1e6 m): the calibrated origin lands
/// beyond it, and `--write-urdf` names the joint (exit 1) rather than writing a file its own
/// reader refuses and calling that a bug.
#[test]
fn a_calibrated_origin_beyond_the_urdf_bound_is_named() {
    let dir = scratch("urdf-bound");
    let joint = |k: usize, xyz: &str, axis: &str| {
        format!(
            "<joint name=\"j{k}\" type=\"revolute\"><parent link=\"l{}\"/><child link=\"l{k}\"/>\
             <origin xyz=\"{xyz}\" rpy=\"0 0 0\"/><axis xyz=\"{axis}\"/>\
             <limit lower=\"-3\" upper=\"3\" effort=\"1\" velocity=\"1\"/></joint>\n",
            k - 1
        )
    };
    let mut urdf = String::from("<?xml version='1.0'?>\n<robot name=\"r\">\n");
    for k in 0..7 {
        urdf.push_str(&format!("<link name=\"l{k}\"/>\n"));
    }
    urdf.push_str("<link name=\"tool\"/>\n");
    for (k, xyz, axis) in [
        (1, "0 0 0.3", "0 0 1"),
        (2, "0 0.1 0.2", "0 1 0"),
        (3, "1e6 0 0", "0 1 0"),
        (4, "0.3 0 0", "1 0 0"),
        (5, "0.1 0 0", "0 1 0"),
        (6, "0.05 0 0", "1 0 0"),
    ] {
        urdf.push_str(&joint(k, xyz, axis));
    }
    urdf.push_str(
        "<joint name=\"tj\" type=\"fixed\"><parent link=\"l6\"/><child link=\"tool\"/>\
         <origin xyz=\"0.05 0 0\" rpy=\"0 0 0\"/></joint>\n</robot>\n",
    );
    let robot = write(&dir, "robot.urdf", &urdf);
    let spec = lincal(&["import", &p(&robot), "--base", "l0", "--tip", "tool"]).ok();
    let spec = write(&dir, "spec.yaml", &spec.stdout);
    let sim = lincal(&["simulate", &p(&spec), "--poses", "80", "--seed", "5"]).ok();
    let data = write(&dir, "data.csv", &sim.stdout);
    let out = dir.join("cal.urdf");
    lincal(&["calibrate", &p(&spec), &p(&data), "--write-urdf", &p(&out)]).fails(
        1,
        &["joint `j3`", "beyond the 1e6 m a URDF origin may hold"],
    );
    assert!(!out.exists(), "nothing is written");
}

/// The outside attack's message classes (issue 50, round 3, second pass): a prior strength
/// given with `--prior off` is refused, not dropped; a subnormal is printed in exponent form;
/// a byte-order mark in a result or truth file is read past; an empty candidates file is
/// named as empty.
#[test]
fn options_and_files_the_attack_found_are_read_or_refused_by_name() {
    let dir = scratch("attack-messages");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let s = p(&root.join("lincal-models/specs/ur5_tracker.yaml"));
    let truth = dir.join("truth.yaml");
    let sim = lincal(&[
        "simulate",
        &s,
        "--poses",
        "60",
        "--seed",
        "3",
        "--truth-out",
        &p(&truth),
    ])
    .ok();
    let data = p(&write(&dir, "d.csv", &sim.stdout));
    lincal(&[
        "calibrate",
        &s,
        &data,
        "--prior",
        "off",
        "--prior-weight",
        "1",
    ])
    .fails(2, &["--prior-weight", "--prior off"]);
    lincal(&["calibrate", &s, &data, "--prior-weight=1e-320"]).fails(2, &["1e-320 is outside"]);
    // A reading of 1e-320 outside q2's limits [-3.1, 0] is shown as such, not in 320 digits.
    let mut rows = sim.stdout.lines();
    let head = rows.next().unwrap_or_default();
    let first: Vec<&str> = rows.next().unwrap_or_default().split(',').collect();
    let mut tiny = first.clone();
    tiny[1] = "1e-320";
    let text = format!("{head}\n{}\n{}\n", first.join(","), tiny.join(","));
    let text = text + &sim.stdout.lines().skip(2).collect::<Vec<_>>().join("\n");
    let sub = p(&write(&dir, "sub.csv", &text));
    let run = lincal(&["calibrate", &s, &sub]).ok();
    assert!(run.stdout.contains("q2 = 1e-320 not in"), "{}", run.stdout);
    // Byte-order marks in front of a result file and a truth file.
    let cal = lincal(&["calibrate", &s, &data, "--format", "json"]).ok();
    let bom = p(&write(&dir, "cal.json", &format!("\u{feff}{}", cal.stdout)));
    lincal(&["predict", &s, "--params", &bom, &data]).ok();
    let t = std::fs::read_to_string(&truth).expect("truth");
    let tb = p(&write(&dir, "truth_bom.yaml", &format!("\u{feff}{t}")));
    lincal(&["simulate", &s, "--poses", "5", "--truth", &tb]).ok();
    // An empty truth file (a truth never written) is refused; `{}` states the nominals.
    for (name, text) in [
        ("empty.yaml", ""),
        ("null.yaml", "null\n"),
        ("c.yaml", "# x\n"),
    ] {
        let e = p(&write(&dir, name, text));
        lincal(&["simulate", &s, "--poses", "3", "--truth", &e])
            .fails(2, &[name, "holds no values"]);
    }
    let nominal = p(&write(&dir, "nominal.yaml", "{}\n"));
    lincal(&["simulate", &s, "--poses", "3", "--truth", &nominal]).ok();
    let header_only = p(&write(&dir, "g0.csv", &format!("{head}\n")));
    lincal(&["select", &s, "-n", "1", "--candidates", &header_only])
        .fails(2, &["--candidates", "hold no poses"]);
}

/// Measured tips in two files (a session split in two, its columns in another order and with
/// an ignored column in the second) fit as the one file they make; files whose joints differ
/// are refused saying what differs.
#[test]
fn measured_tips_in_two_files_fit_as_one() {
    let dir = scratch("two-measured-files");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let s = p(&root.join("lincal-models/specs/ur5_tracker.yaml"));
    let sim = lincal(&["simulate", &s, "--poses", "60", "--seed", "8"]).ok();
    let all = p(&write(&dir, "all.csv", &sim.stdout));
    let lines: Vec<&str> = sim.stdout.lines().collect();
    let first = p(&write(&dir, "a.csv", &(lines[..31].join("\n") + "\n")));
    // The second half with x, y, z first and a column the reader ignores.
    let swap = |l: &str| {
        let c: Vec<&str> = l.split(',').collect();
        format!("{},{},{}", c[6..].join(","), c[..6].join(","), "0")
    };
    let head = swap(lines[0]).replace(",0", ",_note");
    let rest: Vec<String> = lines[31..].iter().map(|l| swap(l)).collect();
    let second = p(&write(
        &dir,
        "b.csv",
        &format!("{head}\n{}\n", rest.join("\n")),
    ));
    let fit = |files: &[&str]| {
        let mut args = vec!["calibrate", s.as_str()];
        args.extend_from_slice(files);
        args.extend_from_slice(&["--format", "json"]);
        lincal(&args).ok().json()["residual_rms"]
            .as_f64()
            .expect("rms")
    };
    let (one, two) = (fit(&[&all]), fit(&[&first, &second]));
    assert!(
        (one - two).abs() <= 1e-12 * one.max(1e-12),
        "{one} vs {two}"
    );
    let short: Vec<String> = lines[31..]
        .iter()
        .map(|l| l.split(',').skip(1).collect::<Vec<_>>().join(","))
        .collect();
    let five = p(&write(
        &dir,
        "c.csv",
        &format!("q1,q2,q3,q4,q5,x,y,z\n{}\n", short.join("\n")),
    ));
    lincal(&["calibrate", &s, &first, &five]).fails(2, &["q6"]);
}

/// Work the attack found unbounded ends at once with the way out: a plan of 1000 poses from
/// 200 000 candidates (minutes before), and `simulate` asked for 2⁶⁴ − 1 poses.
#[test]
fn plans_and_simulations_beyond_their_work_bound_are_refused_at_once() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let s = p(&root.join("lincal-models/specs/ur5_tracker.yaml"));
    let t = std::time::Instant::now();
    lincal(&[
        "select",
        &s,
        "-n",
        "1000",
        "--pool",
        "200000",
        "--criterion",
        "tip",
    ])
    .fails(2, &["--pool", "fewer poses (-n)"]);
    lincal(&["simulate", &s, "--poses", "18446744073709551615"])
        .fails(2, &["--poses", "give 1 to 10000000"]);
    lincal(&["simulate", &s, "--poses", "0"]).fails(2, &["--poses"]);
    assert!(t.elapsed().as_secs() < 10, "refused before any work");
}

/// Failures the spec or the options cause say so: a frame's pitch at ±π/2 named beside the
/// lost combination it makes; a hand-set prior far tighter than the arm's errors warned (the
/// data's own choice is not); a nominal behind a YAML alias named for `--write-spec`.
#[test]
fn failures_the_spec_or_the_options_cause_name_their_cause() {
    let dir = scratch("spec-causes");
    // A three-joint arm in URDF-native rows, every origin entry unknown, joint 2's pitch at
    // π/2 (as `import --convention urdf` writes it, the nominals those of a URDF).
    let nominals = [
        ("1", ["0", "0", "0.3", "0", "0", "0"]),
        ("2", ["0", "0", "0.1", "-pi/2", "pi/2", "0"]),
        ("3", ["0.4", "0", "0", "0", "0", "0"]),
    ];
    let keys = ["x", "y", "z", "roll", "pitch", "yaw"];
    let mut joints = String::new();
    let mut params = String::new();
    for (k, values) in nominals {
        let slots: Vec<String> = keys.iter().map(|key| format!("{key}: {key}{k}")).collect();
        joints.push_str(&format!("  - {{type: revolute, {}}}\n", slots.join(", ")));
        for (key, v) in keys.iter().zip(values) {
            params.push_str(&format!("  {key}{k}: {{nominal: {v}}}\n"));
        }
    }
    for (key, v) in keys.iter().zip(["0"; 6]) {
        params.push_str(&format!("  base_{key}: {{nominal: {v}}}\n"));
    }
    for (key, v) in ["x", "y", "z"].iter().zip(["0.2", "0", "0"]) {
        params.push_str(&format!("  tool_{key}: {{nominal: {v}}}\n"));
    }
    let base = keys
        .iter()
        .map(|k| format!("{k}: base_{k}"))
        .collect::<Vec<_>>()
        .join(", ");
    let pitched = format!(
        "name: r\ndim: 3\nconvention: urdf\njoints:\n{joints}tool: [tool_x, tool_y, tool_z]\n\
         base: {{{base}}}\nparams:\n{params}constraint: measured\n"
    );
    let spec = p(&write(&dir, "pitched.yaml", &pitched));
    let sim = lincal(&["simulate", &spec, "--poses", "200", "--seed", "9"]).ok();
    let data = p(&write(&dir, "d.csv", &sim.stdout));
    lincal(&["calibrate", &spec, &data]).fails(1, &["`pitch2` has the nominal ±π/2"]);

    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let s = p(&root.join("lincal-models/specs/ur5_tracker.yaml"));
    let sim = lincal(&[
        "simulate",
        &s,
        "--poses",
        "100",
        "--seed",
        "3",
        "--noise-measure",
        "1e-5",
    ])
    .ok();
    let data = p(&write(&dir, "u.csv", &sim.stdout));
    let warned = |extra: &[&str]| -> bool {
        let mut args = vec!["calibrate", s.as_str(), data.as_str(), "--format", "json"];
        args.extend_from_slice(extra);
        let run = lincal(&args).ok();
        run.json()["warnings"]
            .as_array()
            .expect("warnings")
            .iter()
            .any(|w| {
                w.as_str()
                    .is_some_and(|w| w.contains("the prior holds the fit"))
            })
    };
    assert!(warned(&["--tolerance-angle", "1e-9"]));
    assert!(!warned(&[]));

    let aliased = "name: odd\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
        - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.4}\n  \
        th1: &x {nominal: 0}\n  a2: {nominal: 0.3}\n  th2: *x\n  xc: {nominal: 0.5}\n  \
        yc: {nominal: 0.1}\nconstraint:\n  point: {p: [xc, yc]}\n";
    let spec = p(&write(&dir, "alias.yaml", aliased));
    let sim = lincal(&["simulate", &spec, "--poses", "40", "--seed", "2"]).ok();
    let data = p(&write(&dir, "a.csv", &sim.stdout));
    let out = p(&dir.join("out.yaml"));
    lincal(&["calibrate", &spec, &data, "--write-spec", &out])
        .fails(2, &["params.th2.nominal", "alias"]);
}
