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

/// A headerless pool (`--no-header --columns`) gives headerless output: every row written is a
/// chosen pose, and it reads back with the same options (its first row is never a header).
#[test]
fn a_headerless_pool_gives_headerless_rows() {
    let dir = scratch("select-headerless");
    let s = spec("point_planar3.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "120", "--seed", "8"]).ok();
    let mut lines = sim.stdout.lines();
    let header = lines.next().expect("a header").to_string();
    let rows: Vec<String> = lines.map(str::to_string).collect();
    let pool = write(&dir, "pool.csv", &(rows.join("\n") + "\n"));
    let run = lincal(&[
        "select",
        &p(&s),
        "-n",
        "10",
        "--candidates",
        &p(&pool),
        "--no-header",
        "--columns",
        &header,
    ])
    .ok();
    let out: Vec<&str> = run.stdout.lines().collect();
    assert_eq!(
        out.len(),
        10,
        "ten chosen rows and no header:\n{}",
        run.stdout
    );
    for row in &out {
        assert!(rows.iter().any(|l| l == row), "{row} is not a pool row");
    }
    let chosen = write(&dir, "chosen.csv", &run.stdout);
    let cal = lincal(&[
        "calibrate",
        &p(&s),
        &p(&chosen),
        "--no-header",
        "--columns",
        &header,
        "--format",
        "json",
    ])
    .ok()
    .json();
    assert_eq!(cal["poses"].as_u64(), Some(10));
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
    // Either source of the pool is named, in the error and in the usage line.
    lincal(&["select", &p(&s), "-n", "3"]).fails(2, &["<--candidates <CANDIDATES>|--pool <POOL>>"]);
    // Sizes that would run for hours or exhaust memory are refused before any work.
    for (opt, value) in [
        ("--draws", "101"),
        ("--draws", "18446744073709551615"),
        ("--pool", "0"),
        ("--pool", "1000001"),
        ("--pool", "18446744073709551615"),
        ("--noise-track", "1e-200"),
    ] {
        let mut args = vec!["select", "-n", "3", opt, value];
        let sp = p(&s);
        let pool_path = p(&pool);
        args.insert(1, &sp);
        if opt != "--pool" {
            args.extend(["--candidates", &pool_path]);
        }
        let run = lincal(&args).fails(2, &[opt, value]);
        // An option's own bound, not a fault of the candidates file.
        assert!(!run.stderr.contains("pool.csv"), "{}", run.stderr);
    }
    // Each bound within range, but together more Jacobians than any machine here holds
    // (10⁶ full poses × 6 rows × 36 parameters × 101 draws: about 210 GB): refused before the pool
    // is built, not killed for its memory.
    lincal(&[
        "select",
        &models("puma560_pose_tracker.yaml"),
        "-n",
        "3",
        "--pool",
        "1000000",
        "--draws",
        "100",
    ])
    .fails(2, &["--pool", "GB for its Jacobians", "fewer --draws"]);
    // A spec whose nominal point the arm cannot reach drops every candidate: the error says
    // so and where to look, not "ask for 1 to 0".
    let text = std::fs::read_to_string(&s).expect("spec");
    let far = write(
        &dir,
        "far.yaml",
        &text.replace("px: {nominal: 0.45}", "px: {nominal: 5.0}"),
    );
    lincal(&["select", &p(&far), "-n", "3", "--candidates", &p(&pool)]).fails(
        2,
        &[
            "no candidate lies on the nominal constraint",
            "20 dropped",
            "--max-off",
        ],
    );
}

/// At its nominals a PUMA 560 (`a5 = a6 = 0`) hides parameters from a plane's poses: planned
/// there alone (`--draws 0`), the plan names them and says how to plan around them, with
/// the prior counted or not (the prior's information on a blind column, scaled by the
/// column's rounding noise, once reached 10³⁰ and ended in "not positive definite").
#[test]
fn nominals_that_hide_parameters_are_named_with_the_way_out() {
    let s = models("puma560_plane.yaml");
    for prior in ["frames", "off"] {
        let run = lincal(&[
            "select", &s, "-n", "30", "--pool", "2000", "--seed", "1", "--draws", "0", "--prior",
            prior,
        ])
        .fails(1, &["at the nominals", "stay unseen", "--draws 3"]);
        assert!(!run.stderr.contains("positive definite"), "{}", run.stderr);
    }
    // Around the nominals the same request is planned.
    lincal(&["select", &s, "-n", "30", "--pool", "2000", "--seed", "1"]).ok();
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

/// `lincal select … --format json` on `pool` with `extra` arguments, parsed.
fn plan_json(spec: &str, pool: &Path, n: usize, extra: &[&str]) -> serde_json::Value {
    let count = n.to_string();
    let pool = p(pool);
    let mut args = vec!["select", spec, "-n", &count, "--candidates", &pool];
    args.extend_from_slice(&["--format", "json"]);
    args.extend_from_slice(extra);
    lincal(&args).ok().json()
}

/// A JSON number array as floats (`null` as infinity).
fn floats(v: &serde_json::Value, key: &str) -> Vec<f64> {
    v["params"]
        .as_array()
        .expect("params")
        .iter()
        .map(|q| q[key].as_f64().unwrap_or(f64::INFINITY))
        .collect()
}

#[test]
fn the_tip_criterion_chooses_pool_rows_with_a_lower_predicted_tip_error() {
    // A PUMA 560 on an unknown plane, 25 of 500: each criterion wins on its own measure, on
    // the same pool, seed and workspace points.
    let dir = scratch("select-tip");
    let s = models("puma560_plane.yaml");
    let sim = lincal(&["simulate", &s, "--poses", "500", "--seed", "5"]).ok();
    let pool = write(&dir, "pool.csv", &sim.stdout);
    let rows: Vec<&str> = sim.stdout.lines().collect();
    let d = plan_json(&s, &pool, 25, &["--criterion", "d"]);
    let tip = plan_json(&s, &pool, 25, &["--criterion", "tip"]);
    assert_eq!(tip["criterion"], "tip");
    let num = |v: &serde_json::Value, k: &str| v[k].as_f64().expect(k);
    assert!(
        num(&tip, "tip_rms") <= num(&d, "tip_rms"),
        "tip criterion {} vs D {}",
        num(&tip, "tip_rms"),
        num(&d, "tip_rms")
    );
    assert!(num(&tip, "tip_rms") < num(&tip, "random_tip_rms"));
    assert!(num(&d, "log_det") >= num(&tip, "log_det"));
    // The chosen rows are distinct pool rows, their readings as the pool's.
    let chosen = tip["chosen"].as_array().expect("chosen");
    assert_eq!(chosen.len(), 25);
    let mut seen = std::collections::HashSet::new();
    for c in chosen {
        let i = c["candidate"].as_u64().expect("candidate") as usize;
        assert!(i < 500 && seen.insert(i), "candidate {i}");
        assert_eq!(
            c["line"].as_u64(),
            Some(i as u64 + 2),
            "line of candidate {i}"
        );
        let q: Vec<f64> = rows[i + 1]
            .split(',')
            .map(|x| x.parse().expect("a number"))
            .collect();
        let got: Vec<f64> = c["q"]
            .as_array()
            .expect("q")
            .iter()
            .map(|x| x.as_f64().expect("a number"))
            .collect();
        assert_eq!(got.len(), q.len().min(got.len()));
        for (a, b) in got.iter().zip(&q) {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} vs {b}");
        }
    }
    // The text output is those rows under the pool's header.
    let text = lincal(&[
        "select",
        &s,
        "-n",
        "25",
        "--candidates",
        &p(&pool),
        "--criterion",
        "tip",
    ])
    .ok();
    let out: Vec<&str> = text.stdout.lines().collect();
    assert_eq!(out[0], rows[0]);
    let mut lines: Vec<&str> = out[1..].to_vec();
    let mut expect: Vec<&str> = chosen
        .iter()
        .map(|c| rows[c["candidate"].as_u64().unwrap_or(0) as usize + 1])
        .collect();
    lines.sort_unstable();
    expect.sort_unstable();
    assert_eq!(lines, expect);
    assert!(text.stderr.contains("tip criterion"));
}

#[test]
fn encoder_noise_enters_each_poses_covariance() {
    let dir = scratch("select-encoder");
    let s = spec("point_planar3.yaml");
    let sim = lincal(&["simulate", &p(&s), "--poses", "300", "--seed", "3"]).ok();
    let pool = write(&dir, "pool.csv", &sim.stdout);
    let sp = p(&s);
    for bad in [
        "--noise-encoder=-1e-3",
        "--noise-encoder=nan",
        "--noise-encoder=inf",
    ] {
        lincal(&["select", &sp, "-n", "10", "--candidates", &p(&pool), bad])
            .fails(2, &["--noise-encoder"]);
    }
    lincal(&[
        "select",
        &sp,
        "-n",
        "10",
        "--candidates",
        &p(&pool),
        "--noise-encoder",
        "-1",
    ])
    .fails(2, &["--noise-encoder", "negative"]);
    // Encoder noise alone (the tracking noise negligible): the residual covariance is
    // σ_enc²·(∂g/∂q)(∂g/∂q)ᵀ, so doubling σ_enc keeps the choice and doubles every std.
    let one = plan_json(
        &sp,
        &pool,
        10,
        &["--noise-track", "1e-12", "--noise-encoder", "1e-4"],
    );
    let two = plan_json(
        &sp,
        &pool,
        10,
        &["--noise-track", "1e-12", "--noise-encoder", "2e-4"],
    );
    assert_eq!(one["sigma"]["encoder"].as_f64(), Some(1e-4));
    assert_eq!(one["chosen"], two["chosen"]);
    for (a, b) in floats(&one, "std").iter().zip(floats(&two, "std")) {
        assert!((b / a - 2.0).abs() < 1e-6, "{a} then {b}");
    }
    // Added to tracking noise it can only lower the information: the same random picks
    // predict larger deviations.
    let plain = plan_json(&sp, &pool, 10, &[]);
    let noisy = plan_json(&sp, &pool, 10, &["--noise-encoder", "1e-4"]);
    for (a, b) in floats(&plain, "random_std")
        .iter()
        .zip(floats(&noisy, "random_std"))
    {
        assert!(b >= *a, "{a} then {b}");
    }
    assert!(noisy["random_log_det"].as_f64() < plain["random_log_det"].as_f64());
}

#[test]
fn a_plan_counts_the_prior_where_the_fit_will_apply_it() {
    // A PUMA 560 with its tool pose measured: `d2`/`d3` lie along the parallel axes 2 and 3,
    // where only their sum moves the tip, so 30 poses leave them weak whatever is chosen and
    // `calibrate` will apply its weak-direction prior; the plan says so and counts it.
    let dir = scratch("select-prior");
    let s = models("puma560_pose_tracker.yaml");
    let sim = lincal(&[
        "simulate",
        &s,
        "--poses",
        "300",
        "--seed",
        "5",
        "--noise-measure",
        "2e-5",
        "--noise-orientation",
        "5e-5",
    ])
    .ok();
    let pool = write(&dir, "pool.csv", &sim.stdout);
    let noise = ["--noise-measure", "2e-5", "--noise-orientation", "5e-5"];
    let with = plan_json(&s, &pool, 30, &noise);
    let weak: Vec<&str> = with["prior"]["weak"]
        .as_array()
        .expect("weak")
        .iter()
        .filter_map(|v| v.as_str())
        .collect();
    assert_eq!(with["prior"]["applied"], true, "{}", with["prior"]);
    assert!(weak.contains(&"d2") && weak.contains(&"d3"), "{weak:?}");
    let mut off_args = noise.to_vec();
    off_args.extend(["--prior", "off"]);
    let off = plan_json(&s, &pool, 30, &off_args);
    assert!(off["prior"].is_null());
    // The posterior std of a weak parameter is below the data's alone, and below the prior's
    // tolerance scale; a well-seen one barely moves.
    let names: Vec<&str> = with["params"]
        .as_array()
        .expect("params")
        .iter()
        .filter_map(|p| p["name"].as_str())
        .collect();
    let at = |n: &str| names.iter().position(|m| *m == n).expect("param");
    let (sw, so) = (floats(&with, "std"), floats(&off, "std"));
    let d2 = at("d2");
    assert!(
        sw[d2] < so[d2] && sw[d2] < 0.05,
        "d2: {} vs {}",
        sw[d2],
        so[d2]
    );
    let a2 = at("a2");
    assert!(
        (sw[a2] / so[a2] - 1.0).abs() < 0.2,
        "a2: {} vs {}",
        sw[a2],
        so[a2]
    );
    // The fit on the chosen rows does apply the prior, on the parameters the plan named.
    let rows = lincal(&[
        "select",
        &s,
        "-n",
        "30",
        "--candidates",
        &p(&pool),
        noise[0],
        noise[1],
        noise[2],
        noise[3],
    ])
    .ok();
    let chosen = write(&dir, "chosen.csv", &rows.stdout);
    let fit = lincal(&["calibrate", &s, &p(&chosen), "--format", "json"])
        .ok()
        .json();
    assert_eq!(fit["prior"]["applied"], true, "{}", fit["prior"]);
    let fit_weak: Vec<&str> = fit["prior"]["weak"]
        .as_array()
        .expect("weak")
        .iter()
        .filter_map(|v| v.as_str())
        .collect();
    assert!(
        fit_weak.contains(&"d2") && fit_weak.contains(&"d3"),
        "{fit_weak:?}"
    );
}

/// Relations are information: a planar arm in two sockets a known distance apart. Without the
/// relation no pose fixes the scale; with it, `select` sees every parameter (as `calibrate`
/// does) and predicts the standard deviations `calibrate` then reports on the chosen rows.
#[test]
fn relations_count_in_the_plan() {
    let dir = scratch("select-relations");
    let spec = write(
        &dir,
        "sockets.yaml",
        "name: sockets\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
         - {type: revolute, a: a2, home: th2}\n  - {type: revolute, a: a3, home: th3}\n\
         params:\n  a1: {nominal: 0.4}\n  th1: {nominal: 0}\n  a2: {nominal: 0.3}\n  \
         th2: {nominal: 0}\n  a3: {nominal: 0.1}\n  th3: {nominal: 0}\n  \
         ux: {nominal: 0.45}\n  uy: {nominal: 0.2}\n  vx: {nominal: 0.45}\n  vy: {nominal: 0.3}\n\
         constraints:\n  - point: {p: [ux, uy]}\n  - point: {p: [vx, vy]}\n\
         relations:\n  - {distance: [0, 1], value: 0.1}\n",
    );
    let s = p(&spec);
    let sim = lincal(&[
        "simulate",
        &s,
        "--poses",
        "300",
        "--seed",
        "3",
        "--noise-track",
        "1e-5",
    ])
    .ok();
    let pool = write(&dir, "pool.csv", &sim.stdout);
    let pool = p(&pool);
    let select = |extra: &[&str]| {
        let mut args = vec![
            "select",
            &s,
            "-n",
            "30",
            "--candidates",
            &pool,
            "--noise-track",
            "1e-5",
        ];
        args.extend_from_slice(extra);
        lincal(&args).ok()
    };
    let plan = select(&["--format", "json"]).json();
    let chosen = write(&dir, "chosen.csv", &select(&[]).stdout);
    let cal = lincal(&["calibrate", &s, &p(&chosen), "--format", "json"])
        .ok()
        .json();
    // Every free parameter's predicted std within a factor of 3 of the fit's.
    for param in plan["params"].as_array().expect("params") {
        let name = param["name"].as_str().expect("a name");
        let (Some(predicted), Some(fitted)) =
            (param["std"].as_f64(), cal["params"][name]["std"].as_f64())
        else {
            continue;
        };
        let ratio = predicted / fitted;
        assert!(
            (1.0 / 3.0..3.0).contains(&ratio),
            "{name}: predicted {predicted:e}, calibrate {fitted:e}"
        );
    }
}
