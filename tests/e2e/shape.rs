//! The shape of the command line's crate and of the Python crate (issue 51): `main.rs` only
//! dispatches, no source file is over [`MAX_FILE_LINES`] lines before its tests, and no two
//! modules import each other, directly or around a cycle. `lincal-core` checks its own stages
//! in its architecture test, whose module reader this shares.

use std::path::{Path, PathBuf};

#[path = "../../lincal-core/tests/architecture/shape.rs"]
mod core_shape;

use core_shape::{cycles, graph, modules_in};

const MAX_FILE_LINES: usize = 600;
const MAX_MAIN_LINES: usize = 150;

fn crate_src(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

fn check(src: &Path) {
    let mods = modules_in(src);
    assert!(mods.len() > 3, "read no modules under {}", src.display());
    let big: Vec<String> = mods
        .iter()
        .filter(|m| m.lines.len() > MAX_FILE_LINES)
        .map(|m| format!("{} ({} lines)", m.file.display(), m.lines.len()))
        .collect();
    assert!(
        big.is_empty(),
        "files over {MAX_FILE_LINES} lines: {big:#?}"
    );
    let c = cycles(&graph(&mods));
    assert!(
        c.is_empty(),
        "import cycles under {}: {c:#?}",
        src.display()
    );
}

#[test]
fn the_command_line_crate_is_in_rooms() {
    let src = crate_src("src");
    check(&src);
    let main = std::fs::read_to_string(src.join("main.rs")).expect("read main.rs");
    let n = main.lines().count();
    assert!(
        n <= MAX_MAIN_LINES,
        "src/main.rs has {n} lines: it only dispatches"
    );
    // One file per subcommand, each with its arguments and its run function.
    for cmd in [
        "basis",
        "calibrate",
        "simulate",
        "select",
        "demo",
        "import",
        "evaluate",
        "compensate",
        "predict",
    ] {
        let file = src.join("cli").join(format!("{cmd}.rs"));
        let text = std::fs::read_to_string(&file).expect("a file per subcommand");
        assert!(
            text.contains("pub fn run("),
            "{} has no run function",
            file.display()
        );
    }
}

#[test]
fn the_python_crate_has_no_cycle_and_no_large_file() {
    check(&crate_src("python/src"));
}

#[test]
fn the_checks_see_a_cycle_and_a_large_file() {
    let dir = std::env::temp_dir().join(format!("lincal-shape-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("lib.rs"), "mod a;\nmod b;\nmod c;\nmod d;\n").expect("write");
    std::fs::write(dir.join("a.rs"), "use crate::b::X;\n").expect("write");
    std::fs::write(dir.join("b.rs"), "use crate::a::Y;\n").expect("write");
    std::fs::write(dir.join("c.rs"), "fn x() {}\n".repeat(MAX_FILE_LINES + 1)).expect("write");
    std::fs::write(dir.join("d.rs"), "").expect("write");
    let mods = modules_in(&dir);
    let c = cycles(&graph(&mods));
    assert_eq!(c, vec![vec!["a".to_string(), "b".to_string()]]);
    assert!(mods.iter().any(|m| m.lines.len() > MAX_FILE_LINES));
    let _ = std::fs::remove_dir_all(&dir);
}
