//! The documentation runs (issue 51): every shell block of `README.md`, `docs/` and
//! `examples/*/README.md`, and every `examples/*/run.sh` with its output checked, so the
//! README, the guide and the examples cannot drift from the program.
//!
//! How a file's blocks run:
//! - every ` ```sh ` (or `bash`) block of a file, in order, in one fresh directory holding
//!   copies of the repository's `examples/`, `lincal-models/specs/`, `tests/urdf/`,
//!   `tests/large/` and `bench/specs/` at the same relative paths, with `bash -euo pipefail`
//!   and the `lincal` this test built first on `PATH`; so commands are written from the
//!   repository's root, and a block may use the files an earlier block of the same file
//!   wrote;
//! - a line that is one of CI's own steps (`cargo …`, `pip …`, `bash .ci/run`,
//!   `bash python/ci.sh`) is not run here: `cargo run --release -- ARGS` runs as
//!   `lincal ARGS`; the others must be commands `.ci/run` or `python/ci.sh` runs (or
//!   `cargo install --path .`, the build this test already made), and are counted;
//! - a block whose info string says `bench` (` ```sh bench `) is a benchmark's command: it
//!   runs too, in the same sandbox, which also holds `bench/` (its Python environment made
//!   once by `bench/venv.sh`, the Ceres peer built once in `bench/ceres/`),
//!   `target/release/lincal` (this test's binary) and `../shared`, with `BENCH_QUICK=1`:
//!   the bench scripts then run their smallest case once (one seed, one round, the smallest
//!   pose count), which proves the documented command still runs, not the figures beside it;
//!   its own `cargo bench`, `cargo build` and `cargo test` lines are CI steps as above;
//! - a fence without an info string must not hold a command: a command block says `sh`.
//!
//! Each `examples/NAME/run.sh` runs with its folder (in a copy of the whole `examples/` tree)
//! as the working directory; its stdout must match `expected.txt` beside it, numbers within a
//! relative 1e-6 (absolute 1e-9), every other word exactly.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// One fenced shell block: its file, the line of its opening fence, its info words and text.
struct Block {
    file: PathBuf,
    line: usize,
    bench: bool,
    text: String,
}

/// The shell blocks of a Markdown text.
fn shell_blocks(file: &Path, text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<(usize, bool, bool, String)> = None;
    for (i, l) in text.lines().enumerate() {
        let t = l.trim_start();
        match &mut open {
            None => {
                if let Some(info) = t.strip_prefix("```") {
                    let mut words = info.split_whitespace();
                    let lang = words.next().unwrap_or("");
                    let shell = matches!(lang, "sh" | "bash" | "shell");
                    let bench = words.any(|w| w == "bench");
                    open = Some((i + 1, shell, bench, String::new()));
                }
            }
            Some((line, shell, bench, body)) => {
                if t.starts_with("```") {
                    if *shell {
                        out.push(Block {
                            file: file.to_path_buf(),
                            line: *line,
                            bench: *bench,
                            text: std::mem::take(body),
                        });
                    }
                    open = None;
                } else {
                    body.push_str(l);
                    body.push('\n');
                }
            }
        }
    }
    assert!(
        open.is_none(),
        "{}: a code fence is never closed",
        file.display()
    );
    out
}

/// The Markdown files whose shell blocks run: `README.md`, `docs/**.md`, `examples/*/README.md`.
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        let mut paths: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
        paths.sort();
        for p in paths {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "md") {
                out.push(p);
            }
        }
    }
    let mut out = vec![root().join("README.md")];
    walk(&root().join("docs"), &mut out);
    walk(&root().join("examples"), &mut out);
    out
}

/// CI's own steps, as a block names them: not run here, each checked against what CI runs.
fn ci_step(line: &str) -> Option<&str> {
    let t = line.trim();
    [
        "cargo ",
        "pip ",
        "pip3 ",
        "bash .ci/run",
        "bash python/ci.sh",
    ]
    .iter()
    .any(|p| t.starts_with(p))
    .then_some(t)
}

/// Whether `.ci/run` or `python/ci.sh` runs the step (comments after `#` left out). CI's
/// `cargo test --workspace --release` builds every package in release and runs every test,
/// so it covers `cargo build --release [-p NAME]` and a filtered `cargo test` of it (not
/// one that adds ignored tests, features or targets); its `cargo test --workspace --release
/// --bench '*'` runs every bench target once (criterion's in test mode), so it covers
/// `cargo bench [-p NAME] [--bench NAME]`.
fn check_ci_step(step: &str, block: &Block) {
    let cmd = step.split('#').next().unwrap_or("").trim();
    let ci = std::fs::read_to_string(root().join(".ci/run")).expect("read .ci/run");
    let py = std::fs::read_to_string(root().join("python/ci.sh")).expect("read python/ci.sh");
    let release_tests = "cargo test --workspace --release";
    let beyond = ["--ignored", "--include-ignored", "--features", "--target"]
        .iter()
        .any(|f| cmd.contains(f));
    let covered = !beyond
        && (ci.contains(release_tests)
            && (cmd.starts_with(release_tests) || cmd.starts_with("cargo build --release"))
            || ci.contains("cargo test --workspace --release --bench '*'")
                && cmd.starts_with("cargo bench"));
    let known = cmd == "bash .ci/run"
        || covered
        || cmd == "cargo install --path ."
        || (cmd.starts_with("pip install") && py.contains("pip install"))
        || ci.contains(cmd)
        || py.contains(cmd);
    assert!(
        known,
        "{}:{}: `{cmd}` is neither run by this test nor a step of .ci/run or python/ci.sh",
        block.file.display(),
        block.line
    );
}

/// A block as this test runs it: `cargo run --release -- ARGS` as `lincal ARGS`, CI's other
/// steps left out (and checked); the number of those.
fn runnable(block: &Block) -> (String, usize) {
    let mut script = String::new();
    let mut steps = 0;
    for l in block.text.lines() {
        if let Some(rest) = l.trim().strip_prefix("cargo run --release -- ") {
            script.push_str("lincal ");
            script.push_str(rest);
        } else if let Some(step) = ci_step(l) {
            check_ci_step(step, block);
            steps += 1;
        } else {
            script.push_str(l);
        }
        script.push('\n');
    }
    (script, steps)
}

/// A sandbox's `lincal/` directory; its top directory is removed when the sandbox is
/// dropped, after a failed assertion too.
struct Sandbox(PathBuf);

impl std::ops::Deref for Sandbox {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl Drop for Sandbox {
    fn drop(&mut self) {
        remove_sandbox(&self.0);
    }
}

/// A fresh directory holding copies of the trees the documentation names (`DIR/lincal`, with
/// `DIR/shared` the repository's `../shared`, as CI lays them out).
fn sandbox(tag: &str) -> Sandbox {
    let top = std::env::temp_dir().join(format!("lincal-docs-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&top);
    let dir = top.join("lincal");
    std::fs::create_dir_all(&dir).expect("create the sandbox");
    let shared = root().join("../shared");
    if shared.exists() {
        std::os::unix::fs::symlink(&shared, top.join("shared")).expect("link ../shared");
    }
    for tree in [
        "examples",
        "lincal-models/specs",
        "tests/urdf",
        "tests/large",
        "bench",
    ] {
        let from = root().join(tree);
        if from.exists() {
            copy_tree(&from, &dir.join(tree));
        }
    }
    // The bench's Python environment and Ceres peer are made once, in the repository.
    for made in ["bench/.venv", "bench/ceres"] {
        if root().join(made).exists() {
            std::os::unix::fs::symlink(root().join(made), dir.join(made)).expect("link");
        }
    }
    let release = dir.join("target/release");
    std::fs::create_dir_all(&release).expect("create target/release");
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_lincal"), release.join("lincal"))
        .expect("link target/release/lincal");
    Sandbox(dir)
}

/// Copies `from` to `to`, leaving out what the bench makes (`out`, `.venv`, the Ceres peer).
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create a directory");
    for e in std::fs::read_dir(from).expect("read a directory").flatten() {
        let p = e.path();
        let name = e.file_name();
        if p.starts_with(root().join("bench"))
            && [".venv", "out", "ceres"].contains(&&*name.to_string_lossy())
        {
            continue;
        }
        let dest = to.join(&name);
        if p.is_dir() {
            copy_tree(&p, &dest);
        } else {
            std::fs::copy(&p, &dest).expect("copy a file");
        }
    }
}

/// The sandbox's top directory (its `lincal/`'s parent), removed after use.
fn remove_sandbox(dir: &Path) {
    let _ = std::fs::remove_dir_all(dir.parent().unwrap_or(dir));
}

/// `bash -euo pipefail -c SCRIPT` in `dir` with this test's `lincal` first on `PATH`, and
/// `HOME`, the cache and `TMPDIR` in the sandbox (a block's `rm -rf ~/.cache/lincal` is its
/// own, its temporary folders go with the sandbox); without the spec-facts cache, except in
/// a benchmark block (`bench` is then whether the Ceres peer was built), which runs with
/// `BENCH_QUICK=1` (and `CERES=0` without the peer) and says itself when it measures cold.
fn bash(script: &str, dir: &Path, bench: Option<bool>) -> std::process::Output {
    let bin = Path::new(env!("CARGO_BIN_EXE_lincal"));
    let path = format!(
        "{}:{}",
        bin.parent().expect("the binary's directory").display(),
        std::env::var("PATH").unwrap_or_default()
    );
    // The sandbox's top: the `lincal-docs-…` directory holding its `lincal/` copy.
    let top_of = |a: &Path| {
        a.file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with("lincal-docs-"))
    };
    let top = dir.ancestors().find(|a| top_of(a)).unwrap_or(dir);
    let (home, tmp) = (top.join("home"), top.join("tmp"));
    std::fs::create_dir_all(&home).expect("create the sandbox's home");
    std::fs::create_dir_all(&tmp).expect("create the sandbox's tmp");
    let mut cmd = Command::new("bash");
    cmd.args(["-euo", "pipefail", "-c", script])
        .current_dir(dir)
        .env("PATH", path)
        .env("HOME", home)
        .env("TMPDIR", tmp)
        .env_remove("XDG_CACHE_HOME")
        .env_remove("LINCAL_CACHE_DIR")
        .env_remove("LINCAL")
        .env_remove("REPS");
    match bench {
        Some(ceres) => {
            cmd.env("BENCH_QUICK", "1").env_remove("LINCAL_CACHE");
            if !ceres {
                cmd.env("CERES", "0");
            }
        }
        None => {
            cmd.env("LINCAL_CACHE", "off");
        }
    }
    cmd.output().expect("run bash")
}

/// The repository paths a benchmark block names (words with a `/` that look like files of
/// the repository: `bench/…`, `lincal-models/…`, `tests/…`).
fn named_repo_paths(text: &str) -> Vec<String> {
    text.split(|c: char| c.is_whitespace() || c == '=' || c == '(' || c == ')')
        .filter(|w| {
            [
                "bench/",
                "lincal-models/",
                "tests/",
                "lincal-core/",
                "scripts/",
            ]
            .iter()
            .any(|p| w.starts_with(p))
        })
        .map(|w| w.trim_end_matches([';', ',', '`', ':']).to_string())
        // Globs, variables, outputs and the venv the bench makes are not the repository's.
        .filter(|w| {
            !w.contains('*') && !w.contains('$') && !w.contains("/out/") && !w.contains(".venv")
        })
        .collect()
}

/// The benchmark chapters, in two halves of about equal running time: the tests below run
/// side by side on CI's two cores.
const BENCH_HALF: [&str; 3] = ["accuracy.md", "peers.md", "compensate.md"];

fn is_benchmark_chapter(f: &Path) -> bool {
    f.parent().is_some_and(|d| d.ends_with("docs/benchmarks"))
}

fn in_first_half(f: &Path) -> bool {
    f.file_name()
        .is_some_and(|n| BENCH_HALF.contains(&&*n.to_string_lossy()))
}

#[test]
fn every_shell_block_of_the_guide_readme_and_examples_runs() {
    let (ran, _) = run_blocks_of(|f| !is_benchmark_chapter(f), "the guide, README, examples");
    assert!(ran > 0, "no shell block ran");
}

#[test]
fn every_benchmark_block_runs_quick_first_half() {
    let (_, benches) = run_blocks_of(
        |f| is_benchmark_chapter(f) && in_first_half(f),
        "benchmarks (accuracy, peers, compensate)",
    );
    assert!(benches > 0, "no benchmark block ran");
}

#[test]
fn every_benchmark_block_runs_quick_second_half() {
    let (_, benches) = run_blocks_of(
        |f| is_benchmark_chapter(f) && !in_first_half(f),
        "benchmarks (cold start, derive, resources, select)",
    );
    assert!(benches > 0, "no benchmark block ran");
}

/// Runs every shell block of the Markdown files `which` picks (module docs), and prints the
/// counts; the shell blocks and the benchmark blocks run.
fn run_blocks_of(which: impl Fn(&Path) -> bool, label: &str) -> (usize, usize) {
    let (mut ran, mut steps, mut benches, mut files) = (0, 0, 0, 0);
    let mut bench_time = std::time::Duration::ZERO;
    for file in markdown_files().into_iter().filter(|f| which(f)) {
        let text = std::fs::read_to_string(&file).expect("read a doc file");
        let bare = bare_command_fences(&text);
        assert!(
            bare.is_empty(),
            "{}: the fences at lines {bare:?} hold commands without saying `sh`",
            file.display()
        );
        let blocks = shell_blocks(&file, &text);
        if blocks.is_empty() {
            continue;
        }
        files += 1;
        let ceres = if blocks.iter().any(|b| b.bench) {
            bench_environment()
        } else {
            true
        };
        let tag = file
            .strip_prefix(root())
            .unwrap_or(&file)
            .display()
            .to_string()
            .replace('/', "_");
        let dir = sandbox(&tag);
        for b in &blocks {
            if b.bench {
                for p in named_repo_paths(&b.text) {
                    assert!(
                        root().join(&p).exists(),
                        "{}:{}: names `{p}`, which the repository does not hold",
                        b.file.display(),
                        b.line
                    );
                }
            }
            let (script, n) = runnable(b);
            steps += n;
            let t = std::time::Instant::now();
            let out = bash(&script, &dir, b.bench.then_some(ceres));
            assert!(
                out.status.success(),
                "{}:{}: the block failed ({}):\n{}\n--- stdout\n{}\n--- stderr\n{}",
                b.file.display(),
                b.line,
                out.status,
                b.text,
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            if b.bench {
                benches += 1;
                bench_time += t.elapsed();
                println!(
                    "docs: {}:{}: benchmark block run quick in {:.1} s",
                    tag,
                    b.line,
                    t.elapsed().as_secs_f64()
                );
            } else {
                ran += 1;
            }
        }
    }
    println!(
        "docs ({label}): {ran} shell blocks run, {benches} benchmark blocks run quick \
         (BENCH_QUICK=1, {:.0} s), {steps} CI steps checked, in {files} files",
        bench_time.as_secs_f64()
    );
    (ran, benches)
}

/// `bash SCRIPT` (a path of the repository) in the repository.
fn script_in_root(script: &str) -> Result<std::process::Output, String> {
    Command::new("bash")
        .arg(script)
        .current_dir(root())
        .output()
        .map_err(|e| format!("{script}: {e}"))
}

/// The lines of the fences without an info string whose first line is a command (`lincal`,
/// `cargo`, `bash`, `python…`, an environment assignment before one): such a block would
/// escape this test, so it must say `sh`.
fn bare_command_fences(text: &str) -> Vec<usize> {
    let mut out = Vec::new();
    let mut open: Option<(usize, bool)> = None;
    for (i, l) in text.lines().enumerate() {
        let t = l.trim_start();
        match open {
            None => {
                if let Some(info) = t.strip_prefix("```") {
                    open = Some((i + 1, info.trim().is_empty()));
                }
            }
            Some((line, bare)) => {
                if t.starts_with("```") {
                    open = None;
                } else if bare {
                    let word = t
                        .split_whitespace()
                        .find(|w| !w.contains('='))
                        .unwrap_or("");
                    let command = [
                        "lincal", "cargo", "bash", "sh", "time", "touch", "rm", "git",
                    ]
                    .contains(&word)
                        || word.starts_with("python")
                        || word.starts_with("bench/");
                    if command {
                        out.push(line);
                    }
                    open = Some((line, false));
                }
            }
        }
    }
    out
}

/// The benchmarks' Python environment (`bench/venv.sh`: numpy, scipy, pyyaml in
/// `bench/.venv`) and the Ceres peer, made once in the repository before the first
/// benchmark block; whether the peer was built (without it `run.sh` runs lincal and scipy).
fn bench_environment() -> bool {
    static MADE: std::sync::OnceLock<Result<bool, String>> = std::sync::OnceLock::new();
    let made = MADE.get_or_init(|| {
        let out = script_in_root("bench/venv.sh")?;
        if !out.status.success() {
            return Err(format!(
                "bench/venv.sh failed:\n{}",
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        // The Ceres peer once, before blocks run side by side; a failed build is said
        // once, and the blocks then run without the peer (`CERES=0`).
        let peer = root().join("bench/ceres/peer_ceres");
        let source = root().join("bench/ceres/peer_ceres.cpp");
        let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
        if modified(&peer) >= modified(&source) {
            return Ok(true);
        }
        let built = script_in_root("bench/ceres/build.sh")?;
        if !built.status.success() {
            println!(
                "docs: the Ceres peer was not built; the benchmark blocks run without it:\n{}",
                String::from_utf8_lossy(&built.stderr)
            );
        }
        Ok(built.status.success())
    });
    match made {
        Ok(ceres) => *ceres,
        Err(why) => panic!("{why}"),
    }
}

/// Whether `a` and `b` are the same output: numbers within a relative 1e-6 (absolute 1e-9),
/// every other token equal; the first difference otherwise.
fn same_output(a: &str, b: &str) -> Result<(), String> {
    let (la, lb): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    if la.len() != lb.len() {
        return Err(format!("{} lines, expected {}", la.len(), lb.len()));
    }
    let split = |l: &str| -> Vec<String> {
        l.split(|c: char| c.is_whitespace() || c == ',' || c == '(' || c == ')' || c == '|')
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .collect()
    };
    for (i, (x, y)) in la.iter().zip(&lb).enumerate() {
        let (tx, ty) = (split(x), split(y));
        let equal = tx.len() == ty.len()
            && tx.iter().zip(&ty).all(|(u, v)| {
                if u == v {
                    return true;
                }
                let num = |s: &str| {
                    s.trim_end_matches(['%', 'x', '×', ';', ':'])
                        .parse::<f64>()
                        .ok()
                };
                match (num(u), num(v)) {
                    (Some(p), Some(q)) => (p - q).abs() <= 1e-9 + 1e-6 * p.abs().max(q.abs()),
                    _ => false,
                }
            });
        if !equal {
            return Err(format!("line {}:\n  got      {x}\n  expected {y}", i + 1));
        }
    }
    Ok(())
}

#[test]
fn every_example_runs_and_prints_what_it_shows() {
    let examples = root().join("examples");
    let mut names: Vec<String> = std::fs::read_dir(&examples)
        .map(|d| {
            d.flatten()
                .filter(|e| e.path().join("run.sh").exists())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    assert!(!names.is_empty(), "no examples/*/run.sh");
    let dir = sandbox("examples");
    for name in &names {
        let folder = dir.join("examples").join(name);
        let out = bash("bash run.sh", &folder, None);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "examples/{name}/run.sh failed ({}):\n--- stdout\n{stdout}\n--- stderr\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        let expected = std::fs::read_to_string(examples.join(name).join("expected.txt"))
            .unwrap_or_else(|_| panic!("examples/{name}/expected.txt is missing"));
        if let Err(why) = same_output(&stdout, &expected) {
            panic!("examples/{name}/run.sh prints other than expected.txt: {why}");
        }
    }
    println!("examples: {} scripts run and checked", names.len());
}

#[test]
fn the_harness_sees_blocks_steps_and_differences() {
    let md = "a\n```sh\nlincal demo\n```\n```text\nno\n```\n```sh bench\nbash bench/run.sh\n```\n";
    let blocks = shell_blocks(Path::new("x.md"), md);
    assert_eq!(blocks.len(), 2);
    assert_eq!(
        (blocks[0].line, blocks[0].bench, blocks[1].bench),
        (2, false, true)
    );
    assert_eq!(named_repo_paths(&blocks[1].text), vec!["bench/run.sh"]);
    let bare = "```\nREPS=5 bash bench/run.sh\n```\n```\n| a | b |\n```\n```text\nlincal x\n```\n";
    assert_eq!(bare_command_fences(bare), vec![1]);
    let b = Block {
        file: "x.md".into(),
        line: 1,
        bench: false,
        text: "cargo run --release -- demo\nbash .ci/run\n".into(),
    };
    assert_eq!(runnable(&b), ("lincal demo\n\n".to_string(), 1));
    assert!(same_output("rms 1.0000001e-3 m\n", "rms 1.0e-3 m\n").is_ok());
    assert!(same_output("rms 1.1e-3 m\n", "rms 1.0e-3 m\n").is_err());
    assert!(same_output("ok\n", "ok\nmore\n").is_err());
    assert!(same_output("status ok\n", "status limit\n").is_err());
}
