//! Issue 50's leftovers (round 3, hostile inputs): each test drives one class of input whose
//! message blamed the wrong thing, or whose figure hid what it left out.

use std::path::Path;

use crate::util::{lincal, scratch, spec, write};

fn p(path: &Path) -> String {
    path.display().to_string()
}

/// A candidates file whose rows repeat a few poses: `select` names the candidates (the file,
/// too few distinct poses, near-duplicates) and never tells the user to change `-n`, which
/// cannot help; a pool that would see every parameter still blames `-n`.
#[test]
fn select_blames_repeated_candidates_not_the_count() {
    let dir = scratch("leftovers-select-duplicates");
    let s = p(&spec("plane_spatial.yaml"));
    let sim = lincal(&["simulate", &s, "--poses", "40", "--seed", "2"]).ok();
    let lines: Vec<&str> = sim.stdout.lines().collect();
    for (distinct, name) in [(1, "one.csv"), (2, "two.csv")] {
        let mut text = format!("{}\n", lines[0]);
        for _ in 0..30 {
            for row in &lines[1..=distinct] {
                text.push_str(row);
                text.push('\n');
            }
        }
        let pool = p(&write(&dir, name, &text));
        for draws in ["3", "0"] {
            let run = lincal(&[
                "select",
                &s,
                "-n",
                "10",
                "--candidates",
                &pool,
                "--draws",
                draws,
            ])
            .fails(1, &[name, "too few distinct poses", "near-duplicates"]);
            assert!(
                run.stderr.contains(&format!("only {distinct} distinct")),
                "{}",
                run.stderr
            );
            assert!(!run.stderr.contains("ask for more poses"), "{}", run.stderr);
        }
    }
    // Four distinct rows for six parameters: too few candidates, not too small an -n.
    let four = p(&write(&dir, "four.csv", &(lines[..5].join("\n") + "\n")));
    let run = lincal(&["select", &s, "-n", "4", "--candidates", &four])
        .fails(1, &["four.csv", "too few candidates"]);
    assert!(!run.stderr.contains("ask for more poses"), "{}", run.stderr);
    // A varied pool asked for too few poses: then -n is the one to change.
    let pool = p(&write(&dir, "varied.csv", &sim.stdout));
    lincal(&["select", &s, "-n", "3", "--candidates", &pool])
        .fails(1, &["3 poses", "ask for more poses (-n)"]);
}
