//! `calibrate --report OUT.html`, checked as a person would: the report is opened in headless
//! Chromium (Debian's `chromium`) when it is installed — no console error, every section
//! there, a screenshot — and checked structurally always (every section, every SVG well-formed
//! XML, no script, nothing fetched from a network). Progress bars: nothing on stderr when it
//! is not a terminal, a bar when it is (under `script`'s pseudo-terminal, where installed).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::util::{lincal, scratch, spec};

/// Every section of a report, measured tips included.
const SECTIONS: [&str; 11] = [
    "summary",
    "parameters",
    "gauge",
    "residuals",
    "histogram",
    "worst",
    "leverage",
    "tip-errors",
    "accuracy",
    "identifiability",
    "reproduce",
];

fn adept() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("lincal-models/specs/adept_one.yaml")
}

/// `program` when it is on `PATH`.
fn on_path(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

/// Runs a command to its end or `limit` (then kills it); (status ok, stdout, stderr).
fn run_limited(cmd: &mut Command, limit: Duration) -> (bool, String, String) {
    // A directory of its own per call: tests run in parallel.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = scratch(&format!("report-run-limited-{call}"));
    let (out, err) = (dir.join("out"), dir.join("err"));
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).expect("stdout file"))
        .stderr(std::fs::File::create(&err).expect("stderr file"))
        .spawn()
        .expect("cannot start the command");
    let start = Instant::now();
    let ok = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status.success();
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{cmd:?} did not finish within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let read =
        |p: &Path| String::from_utf8_lossy(&std::fs::read(p).unwrap_or_default()).into_owned();
    (ok, read(&out), read(&err))
}

/// Simulates `poses` poses of `spec` into `dir/name`.
fn simulate(dir: &Path, name: &str, spec: &Path, poses: usize, noise: &[&str]) -> PathBuf {
    let mut args = vec![
        "simulate".to_string(),
        spec.display().to_string(),
        "--poses".to_string(),
        poses.to_string(),
        "--seed".to_string(),
        "7".to_string(),
    ];
    args.extend(noise.iter().map(|s| (*s).to_string()));
    let run = lincal(&args).ok();
    let path = dir.join(name);
    std::fs::write(&path, run.stdout).expect("write data");
    path
}

/// The structural checks, whatever is installed: sections, SVGs as XML, no script, no
/// network reference, the inputs' hashes.
fn check_structure(html: &str, measured: bool, data: &Path) {
    assert!(html.starts_with("<!DOCTYPE html>"));
    for id in SECTIONS {
        let present = html.contains(&format!("<section id=\"{id}\">"));
        assert_eq!(present, id != "tip-errors" || measured, "section `{id}`");
    }
    assert!(!html.to_ascii_lowercase().contains("<script"), "a script");
    for attr in ["src=", "href=", "url("] {
        for (i, _) in html.match_indices(attr) {
            let value: String = html[i + attr.len()..].chars().take(12).collect();
            let v = value.trim_start_matches(['"', '\'']);
            assert!(
                !v.starts_with("http:") && !v.starts_with("https:") && !v.starts_with("//"),
                "a network reference: {attr}{value}"
            );
        }
    }
    // Every SVG is well-formed XML with drawing in it.
    let mut svgs = 0;
    let mut rest = html;
    while let Some(start) = rest.find("<svg") {
        let end = rest[start..].find("</svg>").expect("an unclosed <svg>") + start + 6;
        let doc = roxmltree::Document::parse(&rest[start..end])
            .unwrap_or_else(|e| panic!("SVG {svgs} is not XML: {e}"));
        assert_eq!(doc.root_element().tag_name().name(), "svg");
        assert!(doc.descendants().count() > 20, "SVG {svgs} is nearly empty");
        svgs += 1;
        rest = &rest[end..];
    }
    // The prior's cross-validation curve, when the data chose its strength.
    let prior_plot = usize::from(html.contains("<section id=\"prior\">"));
    // ... and the accuracy map (every report here has standard deviations).
    assert_eq!(svgs, if measured { 5 } else { 4 } + prior_plot, "plots");
    assert!(
        html.contains("predicted 1σ tip uncertainty"),
        "the accuracy map's caption"
    );
    check_leverage(html);
    // The data file's size and a 64-digit hash in the reproducibility table.
    let bytes = std::fs::metadata(data).expect("data").len();
    assert!(html.contains(&format!("<td class=\"num\">{bytes}</td>")));
    let hex64 = html
        .split(|c: char| !c.is_ascii_hexdigit())
        .filter(|w| w.len() == 64)
        .count();
    assert!(hex64 >= 2, "the two input hashes");
    assert!(html.contains("--report"), "the command line");
}

/// The leverage section: the leverages sum to the rank (the free parameters the data
/// determine), and the poses of highest leverage are named.
fn check_leverage(html: &str) {
    let start = html
        .find("<section id=\"leverage\">")
        .expect("a leverage section");
    let section = &html[start..start + html[start..].find("</section>").expect("its end")];
    let after = |key: &str| -> f64 {
        let i = section
            .find(key)
            .unwrap_or_else(|| panic!("{key} in {section}"))
            + key.len();
        section[i..]
            .split(|c: char| !(c.is_ascii_digit() || c == '.'))
            .next()
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("a number after {key}"))
    };
    let (sum, rank) = (after("Σ h = "), after("the rank "));
    assert!(
        rank >= 1.0 && (sum - rank).abs() < 1e-6,
        "Σ h = {sum}, rank {rank}"
    );
    assert!(section.contains("<svg"), "a leverage plot");
    assert!(
        section.contains("share of Σ h"),
        "the poses of highest leverage"
    );
}

/// Opens the report in headless Chromium: no console message, every section in the DOM it
/// built, a screenshot (`LINCAL_UPDATE_SCREENSHOT=1` also writes it to `docs/report.png`).
fn check_in_chromium(chromium: &Path, html_path: &Path, measured: bool, shot_name: &str) {
    let url = format!("file://{}", html_path.display());
    let common = [
        "--headless",
        "--disable-gpu",
        "--no-sandbox",
        "--hide-scrollbars",
        "--enable-logging=stderr",
        "--log-level=0",
    ];
    let (ok, dom, log) = run_limited(
        Command::new(chromium)
            .args(common)
            .arg("--dump-dom")
            .arg(&url),
        Duration::from_secs(120),
    );
    assert!(ok, "chromium --dump-dom failed:\n{log}");
    let console: Vec<&str> = log
        .lines()
        .filter(|l| l.contains(":CONSOLE") || l.contains("Uncaught"))
        .collect();
    assert!(
        console.is_empty(),
        "console messages:\n{}",
        console.join("\n")
    );
    for id in SECTIONS {
        let present = dom.contains(&format!("<section id=\"{id}\">"));
        assert_eq!(
            present,
            id != "tip-errors" || measured,
            "rendered section `{id}`"
        );
    }
    assert_eq!(dom.matches("<svg").count(), if measured { 4 } else { 3 });
    let shot = html_path.with_file_name(shot_name);
    let (ok, _, log) = run_limited(
        Command::new(chromium)
            .args(common)
            .arg("--window-size=1000,3400")
            .arg(format!("--screenshot={}", shot.display()))
            .arg(&url),
        Duration::from_secs(120),
    );
    assert!(ok, "chromium --screenshot failed:\n{log}");
    let png = std::fs::read(&shot).expect("no screenshot written");
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 20_000,
        "a blank screenshot?"
    );
    if !measured && std::env::var_os("LINCAL_UPDATE_SCREENSHOT").is_some() {
        let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/report.png");
        std::fs::write(&docs, &png).expect("cannot write docs/report.png");
    }
}

#[test]
fn report_is_a_complete_self_contained_page() {
    let dir = scratch("report-page");
    let chromium = on_path("chromium").or_else(|| on_path("chromium-browser"));
    if chromium.is_none() {
        println!(
            "note: chromium is not installed (apt-get install chromium): the report is checked \
             structurally only, not rendered"
        );
    }
    for (measured, spec_path, noise) in [
        (false, adept(), &["--noise-track", "30e-6"][..]),
        (
            true,
            spec("measured_spatial.yaml"),
            &["--noise-measure", "20e-6"][..],
        ),
    ] {
        let stem = spec_path
            .file_stem()
            .expect("a spec file name")
            .to_string_lossy()
            .into_owned();
        let data = simulate(&dir, &format!("{stem}.csv"), &spec_path, 300, noise);
        let out = dir.join(format!("{stem}-report.html"));
        // The report run from the scratch directory with relative paths, as a person types
        // it (and as the README's screenshot shows it).
        let spec_copy = format!("{stem}.yaml");
        std::fs::copy(&spec_path, dir.join(&spec_copy)).expect("copy the spec");
        let report_run = Command::new(env!("CARGO_BIN_EXE_lincal"))
            .current_dir(&dir)
            .args(["calibrate", &spec_copy, &format!("{stem}.csv"), "--refine"])
            .args(["--report", &format!("{stem}-report.html")])
            .output()
            .expect("run lincal");
        let plain = lincal(&[
            "calibrate".as_ref(),
            spec_path.as_os_str(),
            data.as_os_str(),
            "--refine".as_ref(),
        ])
        .ok();
        assert!(report_run.status.success());
        assert_eq!(
            plain.stdout,
            String::from_utf8_lossy(&report_run.stdout),
            "--report changes stdout"
        );
        assert!(
            report_run.stderr.is_empty(),
            "stderr is not a terminal: no progress"
        );
        let html = std::fs::read_to_string(&out).expect("no report written");
        check_structure(&html, measured, &data);
        // The worst pose's CSV line is quoted.
        let json = lincal(&[
            "calibrate".as_ref(),
            spec_path.as_os_str(),
            data.as_os_str(),
            "--refine".as_ref(),
            "--format".as_ref(),
            "json".as_ref(),
        ])
        .ok()
        .json();
        let line = json["worst_poses"][0]["line"].as_u64().expect("a line") as usize;
        let text = std::fs::read_to_string(&data).expect("data");
        let csv_line = text.lines().nth(line - 1).expect("the line");
        assert!(
            html.contains(&format!("<code>{csv_line}</code>")),
            "{csv_line}"
        );
        if let Some(chromium) = &chromium {
            check_in_chromium(chromium, &out, measured, &format!("{stem}.png"));
        }
    }
}

#[test]
fn report_path_errors_exit_2_naming_the_path() {
    let dir = scratch("report-errors");
    let data = simulate(&dir, "d.csv", &adept(), 30, &[]);
    let missing = dir.join("no/such/dir/r.html");
    lincal(&[
        "calibrate".as_ref(),
        adept().as_os_str(),
        data.as_os_str(),
        "--report".as_ref(),
        missing.as_os_str(),
    ])
    .fails(2, &["no/such/dir/r.html", "cannot write the report"]);
    lincal(&[
        "calibrate".as_ref(),
        adept().as_os_str(),
        data.as_os_str(),
        "--report".as_ref(),
        dir.as_os_str(),
    ])
    .fails(2, &["cannot write the report", "directory"]);
}

#[test]
fn progress_only_on_a_terminal() {
    let dir = scratch("report-progress");
    // 10⁵ poses: the threshold. Stderr is a pipe here: nothing on it.
    let big = simulate(&dir, "big.csv", &adept(), 100_000, &[]);
    let run = lincal(&[
        "simulate".as_ref(),
        adept().as_os_str(),
        "--poses".as_ref(),
        "100000".as_ref(),
    ])
    .ok();
    assert_eq!(run.stderr, "");
    let run = lincal(&["calibrate".as_ref(), adept().as_os_str(), big.as_os_str()]).ok();
    assert_eq!(run.stderr, "");
    // On a terminal (util-linux `script` gives the program a pseudo-terminal), a bar.
    let Some(script) = on_path("script") else {
        println!("note: `script` is not installed: the terminal side is not checked");
        return;
    };
    let cmd = format!(
        "{} simulate {} --poses 200000 > {}",
        env!("CARGO_BIN_EXE_lincal"),
        adept().display(),
        dir.join("tty.csv").display()
    );
    let (ok, tty, _) = run_limited(
        Command::new(script).args(["-qec", &cmd, "/dev/null"]),
        Duration::from_secs(120),
    );
    assert!(ok, "{tty}");
    assert!(
        tty.contains("simulating"),
        "no progress bar on a terminal: {tty:?}"
    );
    let rows = std::fs::read_to_string(dir.join("tty.csv")).expect("csv");
    assert_eq!(rows.lines().count(), 200_001, "stdout stays pure CSV");
}
