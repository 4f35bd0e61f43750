//! `lincal select` (issue 24): the chosen rows are pool rows in the data format, the
//! summary says what they are worth, bad requests are refused by name, and the selection
//! beats random picks of the same pool when the chosen poses are calibrated against a truth.

use std::path::Path;

use crate::util::{lincal, scratch, spec, write};

fn p(path: &Path) -> String {
    path.display().to_string()
}

fn models(name: &str) -> String {
    p(&Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("lincal-models/specs")
        .join(name))
}

#[test]
fn candidates_rows_come_back_unchanged_and_off_constraint_rows_are_dropped() {
    let dir = scratch("select-candidates");
    let s = spec("point_planar3.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "200", "--seed", "7"]).ok();
    // Two rows far from the point: the first joint turned by a radian.
    let mut lines: Vec<String> = sim.stdout.lines().map(str::to_string).collect();
    for k in [5, 9] {
        let mut cells: Vec<String> = lines[k].split(',').map(str::to_string).collect();
        let q1: f64 = cells[0].parse().expect("a number");
        cells[0] = format!("{}", q1 + 1.0);
        lines[k] = cells.join(",");
    }
    let pool = write(&dir, "pool.csv", &(lines.join("\n") + "\n"));
    let run = lincal(&["select", &p(&s), "-n", "12", "--candidates", &p(&pool)]).ok();
    let out: Vec<&str> = run.stdout.lines().collect();
    assert_eq!(out[0], lines[0], "the pool's header");
    assert_eq!(out.len(), 13);
    for row in &out[1..] {
        assert!(lines.iter().any(|l| l == row), "{row} is not a pool row");
    }
    assert!(run.stderr.contains("dropped: line 6") && run.stderr.contains("dropped: line 10"));
    // The chosen rows calibrate.
    let chosen = write(&dir, "chosen.csv", &run.stdout);
    lincal(&["calibrate", &p(&s), &p(&chosen)]).ok();
    let json = lincal(&[
        "select",
        &p(&s),
        "-n",
        "12",
        "--candidates",
        &p(&pool),
        "--format",
        "json",
    ])
    .ok()
    .json();
    assert_eq!(json["chosen"].as_array().map(Vec::len), Some(12));
    assert_eq!(json["dropped"].as_array().map(Vec::len), Some(2));
    let params = json["params"].as_array().expect("params");
    assert!(params
        .iter()
        .all(|q| q["std"].as_f64().is_some_and(|v| v > 0.0)));
}

#[test]
fn bad_requests_are_refused_by_name() {
    let dir = scratch("select-bad");
    let s = spec("point_planar3.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "20", "--seed", "7"]).ok();
    let pool = write(&dir, "pool.csv", &sim.stdout);
    lincal(&["select", &p(&s), "-n", "21", "--candidates", &p(&pool)])
        .fails(2, &["-n", "21 poses asked from a pool of 20"]);
    // Two 2-D points give 4 equations for more free parameters than that.
    lincal(&["select", &p(&s), "-n", "2", "--candidates", &p(&pool)])
        .fails(1, &["cannot determine all", "stay unseen"]);
    lincal(&["select", &p(&s), "-n", "3"]).fails(2, &["--candidates"]);
}

#[test]
fn given_poses_enter_first() {
    let dir = scratch("select-given");
    let s = spec("point_planar3.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "300", "--seed", "3"]).ok();
    let pool = write(&dir, "pool.csv", &sim.stdout);
    let done = lincal(&["simulate", &p(&s), "--poses", "40", "--seed", "4"]).ok();
    let done = write(&dir, "done.csv", &done.stdout);
    let std = |extra: &[&str]| -> Vec<f64> {
        let mut args = vec!["select", "-n", "2", "--format", "json", "--candidates"];
        let (sp, pp) = (p(&s), p(&pool));
        args.insert(1, &sp);
        args.push(&pp);
        args.extend_from_slice(extra);
        let v = lincal(&args).ok().json();
        v["params"]
            .as_array()
            .expect("params")
            .iter()
            .map(|q| q["std"].as_f64().unwrap_or(f64::INFINITY))
            .collect()
    };
    // Two poses alone cannot see the free parameters; with forty given they add to them.
    lincal(&["select", &p(&s), "-n", "2", "--candidates", &p(&pool)]).fails(1, &["unseen"]);
    let with = std(&["--given", &p(&done)]);
    assert!(with.iter().all(|v| v.is_finite() && *v > 0.0), "{with:?}");
}

#[test]
fn selected_poses_calibrate_better_than_random_ones_of_the_same_pool() {
    // A small fixed-seed case of the recovery benchmark: PUMA 560 on an unknown plane, the
    // pool simulated on the true robot with noise, the choice from the nominals only.
    let dir = scratch("select-recovery");
    let s = models("puma560_plane.yaml");
    let truth = dir.join("truth.yaml");
    let pool = lincal(&[
        "simulate",
        &s,
        "--poses",
        "2000",
        "--seed",
        "11",
        "--noise-track",
        "1e-5",
        "--truth-out",
        &p(&truth),
    ])
    .ok();
    let pool_path = write(&dir, "pool.csv", &pool.stdout);
    let chosen = lincal(&["select", &s, "-n", "25", "--candidates", &p(&pool_path)]).ok();
    let chosen = write(&dir, "chosen.csv", &chosen.stdout);
    let fresh = lincal(&[
        "simulate",
        &s,
        "--poses",
        "300",
        "--seed",
        "12",
        "--truth",
        &p(&truth),
    ])
    .ok();
    let fresh = write(&dir, "fresh.csv", &fresh.stdout);
    let err = |data: &Path| -> f64 {
        // The fitted model judged on fresh poses of the true robot: its residual there.
        let fit = lincal(&["calibrate", &s, &p(data), "--format", "json"]).ok();
        let result = write(&dir, "result.json", &fit.stdout);
        let ev = lincal(&[
            "evaluate",
            &s,
            &p(&fresh),
            "--params",
            &p(&result),
            "--format",
            "json",
        ])
        .ok()
        .json();
        ev["residual_rms"].as_f64().expect("residual_rms")
    };
    let selected = err(&chosen);
    let rows: Vec<&str> = pool.stdout.lines().collect();
    let mut worse = 0;
    for k in 0..3 {
        // Every 80th row from an offset: random picks of the same pool, fixed.
        let pick: Vec<&str> = std::iter::once(rows[0])
            .chain(rows[1..].iter().skip(k * 7).step_by(80).take(25).copied())
            .collect();
        let random = write(&dir, &format!("random{k}.csv"), &(pick.join("\n") + "\n"));
        if err(&random) > selected {
            worse += 1;
        }
    }
    assert!(
        worse >= 2,
        "selected {selected:e} beat only {worse} of 3 random picks"
    );
}
