//! Resources: a million-row CSV through `lincal calibrate`, its peak memory measured (the
//! child's own `ru_maxrss` from `wait4`, so the other tests' processes running beside it do
//! not count) and bounded.

use std::path::Path;
use std::process::{Command, Stdio};

/// Peak resident memory allowed to `lincal calibrate` on a million planar poses, bytes: four
/// times what the poses themselves take (32 MB: two readings, a constraint index and a line
/// number per pose). Measured: 52 MB (BENCHMARKS.md).
const PEAK_BOUND: u64 = 128 << 20;

/// Runs `lincal` with `args`, stdout to `out`; its exit status, peak resident memory in
/// bytes, and stderr. The child is reaped by `wait4` (not `Child::wait`, which does not
/// return the resource usage), hence the lint's exception.
#[allow(clippy::zombie_processes)]
fn run_measured(args: &[&str], out: &Path) -> (i32, u64, String) {
    let stdout = std::fs::File::create(out).expect("cannot create the output file");
    let child = Command::new(env!("CARGO_BIN_EXE_lincal"))
        .args(args)
        .stdout(Stdio::from(stdout))
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot run the lincal binary");
    let pid = libc::pid_t::try_from(child.id()).expect("a pid fits pid_t");
    // Stderr is small (warnings); read it to its end, then reap the child with wait4 for its
    // own resource usage (std's wait does not return it).
    let mut stderr = String::new();
    if let Some(mut e) = child.stderr {
        use std::io::Read;
        let _ = e.read_to_string(&mut stderr);
    }
    let mut status: libc::c_int = 0;
    // SAFETY: `rusage` is plain data that wait4 fills in; `pid` is our own unreaped child.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let got = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(
        got,
        pid,
        "wait4 failed: {}",
        std::io::Error::last_os_error()
    );
    let code = if libc::WIFEXITED(status) {
        libc::WEXITSTATUS(status)
    } else {
        -1
    };
    // ru_maxrss is in kilobytes on Linux.
    let peak = u64::try_from(usage.ru_maxrss).unwrap_or(0) * 1024;
    (code, peak, stderr)
}

/// A million rows: `lincal simulate` makes 100 000 poses (a million would take it 6-9 s, most
/// of the test), written out ten times over; `calibrate`'s memory and work depend on the row
/// count, not on whether rows repeat.
#[test]
fn a_million_rows_through_calibrate_in_bounded_memory() {
    let dir = crate::util::scratch("resource-million");
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("lincal-models/specs/adept_one.yaml");
    let spec = spec.display().to_string();
    let part = dir.join("part.csv");
    let truth = dir.join("truth.yaml");
    let (code, _, err) = run_measured(
        &[
            "simulate",
            &spec,
            "--poses",
            "100000",
            "--seed",
            "7",
            "--noise-track",
            "1e-5",
            "--truth-out",
            &truth.display().to_string(),
        ],
        &part,
    );
    assert_eq!(code, 0, "simulate failed: {err}");
    let text = std::fs::read_to_string(&part).expect("the CSV");
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().expect("a header");
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 100_000);
    let data = dir.join("million.csv");
    {
        use std::io::Write;
        let mut w = std::io::BufWriter::new(std::fs::File::create(&data).unwrap());
        writeln!(w, "{header}").unwrap();
        for _ in 0..10 {
            for r in &rows {
                writeln!(w, "{r}").unwrap();
            }
        }
        w.flush().unwrap();
    }

    let json = dir.join("result.json");
    let (code, peak, err) = run_measured(
        &[
            "calibrate",
            &spec,
            &data.display().to_string(),
            "--format",
            "json",
        ],
        &json,
    );
    assert_eq!(code, 0, "calibrate failed: {err}");
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("the result")).unwrap();
    eprintln!(
        "lincal calibrate, 10^6 rows: peak RSS {:.1} MB (bound {} MB)",
        peak as f64 / 1048576.0,
        PEAK_BOUND >> 20
    );
    assert!(peak > 0, "no resource usage reported");
    assert!(
        peak < PEAK_BOUND,
        "peak RSS {} MB, bound {} MB",
        peak >> 20,
        PEAK_BOUND >> 20
    );
    // Every row used, and the fit right: the noise level comes back.
    assert_eq!(result["poses"], 1_000_000);
    let rms = result["residual_rms"].as_f64().unwrap();
    assert!((0.9e-5..1.1e-5).contains(&rms), "residual rms {rms}");
    // The identifiable ratio a2/a1 against the simulated truth.
    let t = std::fs::read_to_string(&truth).unwrap();
    let tv = |name: &str| -> f64 {
        t.lines()
            .find_map(|l| l.strip_prefix(&format!("{name}:")))
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or_else(|| panic!("{name} in the truth file:\n{t}"))
    };
    let v = |name: &str| result["params"][name]["value"].as_f64().unwrap();
    let ratio = v("a2") / v("a1");
    assert!(
        (ratio - tv("a2") / tv("a1")).abs() < 1e-5,
        "a2/a1 {ratio} vs {}",
        tv("a2") / tv("a1")
    );
}

/// `lincal basis SPEC --format json` of `tests/large/NAME.yaml`, which must succeed.
fn large_basis(name: &str) -> serde_json::Value {
    let spec = format!("{}/tests/large/{name}.yaml", env!("CARGO_MANIFEST_DIR"));
    crate::util::lincal(&["basis", spec.as_str(), "--format", "json"])
        .ok()
        .json()
}

/// `lincal basis` at the default options where the direct expansion would pass its bound by
/// orders of magnitude (issue 48, build item 5): a 6-joint arm on an unknown quadric, URDF-
/// native rows of 9 joints on a point and of 8 on a sphere, every parameter unknown. Each
/// basis is the full grid of joint functions, proven stage by stage (`symbolic/coverage.rs`),
/// with the identifiable count of the complete model (4 a revolute joint, 6 for the base
/// frame and the tool point, less the constraint's gauge) and `c(p)` left to the kernel. On a
/// quadric with a diagonal `A` the off-diagonal moments never reach the equation: 9 861 of the
/// `5⁶` products arise, each proven in the row space; on a cylinder about the base's axis the
/// first turn cancels too, 17 083 of `5⁷` (session 32; both refused before).
#[test]
fn grid_bases_beyond_the_expansion_have_their_basis_at_the_defaults() {
    for (name, k, identifiable, route) in [
        (
            "arm6_all_unknown_quadric",
            15_625,
            29,
            "full grid of joint functions",
        ),
        (
            "urdf9_all_unknown_point",
            19_683,
            35,
            "full grid of joint functions",
        ),
        (
            "urdf8_all_unknown_sphere",
            6_561,
            32,
            "full grid of joint functions",
        ),
        (
            "arm6_diagonal_quadric",
            9_861,
            27,
            "9861 products of joint functions that can arise (of the 15625 in the grid)",
        ),
        (
            "arm7_cylinder",
            17_083,
            28,
            "17083 products of joint functions that can arise (of the 78125 in the grid)",
        ),
    ] {
        let r = large_basis(name);
        assert_eq!(r["basis_size"], k, "{name}");
        assert_eq!(r["naive_size"], k, "{name}");
        assert_eq!(r["identifiable_count"], identifiable, "{name}");
        assert_eq!(r["generalized_params"].as_array().map(Vec::len), Some(0));
        let warnings = r["warnings"].to_string();
        assert!(warnings.contains(route), "{name}: {warnings}");
    }
}

/// `lincal basis` of a 9-joint arm with every DH parameter unknown, at the default options
/// (issue 48: no `--max-terms` refusal up to 9 joints): the basis is every joint monomial,
/// `3⁹`, and the identifiable count the complete model's for a pinned point behind a fixed
/// base, `4·9 + 6 − 4 − 3` (time and memory: docs/benchmarks/derive.md). The spec lies
/// outside `tests/specs`, whose every spec the engine's own tests expand.
#[test]
fn a_nine_joint_arm_with_every_parameter_unknown_has_its_basis_at_the_defaults() {
    let r = large_basis("arm9_all_unknown_point");
    assert_eq!(r["basis_size"], 19_683);
    assert_eq!(r["identifiable_count"], 35);
}

/// `lincal basis` of a 4-joint arm with every DH parameter, the tool and the quadric unknown,
/// at the default options (issue 48: refused before, the quadric's `xᵀAx` formed from the
/// squared tip, about 6.5·10⁶ terms; now its second moments `x xᵀ` are carried along the
/// chain, 1.4 s): the basis is every joint monomial of degree two a joint, `5⁴`.
#[test]
fn a_four_joint_arm_on_an_unknown_quadric_has_its_basis_at_the_defaults() {
    let r = large_basis("arm4_all_unknown_quadric");
    assert_eq!(r["basis_size"], 625);
    assert_eq!(r["identifiable_count"], 21);
}

/// `calibrate` at its default start on the same 9-joint arm with far fewer poses than `K`
/// starts from the nominals (issue 50, round 3: the expansion took 20 s and 3.7 GB once its
/// default bound held 9 joints). Since session 31 the basis is the full grid, proven without
/// the expansion: `K` = 3⁹ is known at once, beyond the 400 poses, and no bound was met.
#[test]
fn an_automatic_start_with_fewer_poses_than_k_starts_from_the_nominals() {
    let dir = crate::util::scratch("auto-nine");
    let spec = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/large/arm9_all_unknown_point.yaml"
    );
    // Enough poses that a sampled proof of `K` beyond them is out of reach (over 128).
    let sim = crate::util::lincal(&["simulate", spec, "--poses", "400", "--seed", "9"]).ok();
    let data = crate::util::write(&dir, "d.csv", &sim.stdout);
    let r = crate::util::lincal(&[
        "calibrate",
        spec,
        data.to_str().expect("a UTF-8 path"),
        "--format",
        "json",
    ])
    .ok()
    .json();
    assert_eq!(r["start"], "nominal");
    // Reported, though the expansion passes the report's bound: a full grid is known.
    assert_eq!(r["basis_size"], 19_683);
    let warnings = r["warnings"].to_string();
    assert!(
        !warnings.contains("`--start linear` builds it"),
        "{warnings}"
    );
    assert!(
        !warnings.contains("beyond the expansion's bound"),
        "{warnings}"
    );
}

/// `--start linear` on a basis of thousands of functions with as many poses (the attack's
/// 8R arm, every DH parameter unknown, `K` = 6 561, 7 000 poses): refused at once by the
/// solve's cost (`LINEAR_LIMIT`), not run for many minutes or aborted by the allocator.
#[test]
fn a_linear_start_beyond_its_cost_is_refused_by_name() {
    let dir = crate::util::scratch("linear-limit");
    let mut spec = String::from("name: arm8\ndim: 3\njoints:\n");
    let mut params = String::from("params:\n");
    for i in 1..=8 {
        spec.push_str(&format!(
            "  - {{type: revolute, a: a{i}, alpha: al{i}, d: d{i}, home: th{i}}}\n"
        ));
        let twist = if i % 2 == 0 { "-pi/2" } else { "pi/2" };
        params.push_str(&format!(
            "  a{i}: {{nominal: 0.05}}\n  al{i}: {{nominal: {twist}}}\n  d{i}: {{nominal: 0.1}}\n  th{i}: {{nominal: 0}}\n"
        ));
    }
    spec.push_str("tool: [tx, ty, tz]\n");
    spec.push_str(&params);
    spec.push_str("  tx: {nominal: 0.05}\n  ty: {nominal: 0}\n  tz: {nominal: 0.04}\n");
    spec.push_str("  px: {nominal: 0.5}\n  py: {nominal: 0.1}\n  pz: {nominal: 0.2}\n");
    spec.push_str("constraint:\n  point: {p: [px, py, pz]}\n");
    let spec = crate::util::write(&dir, "arm8.yaml", &spec);
    let spec = spec.to_str().expect("a UTF-8 path");
    let sim = crate::util::lincal(&["simulate", spec, "--poses", "7000", "--seed", "2"]).ok();
    let data = crate::util::write(&dir, "d.csv", &sim.stdout);
    crate::util::lincal(&[
        "calibrate",
        spec,
        data.to_str().expect("a UTF-8 path"),
        "--start",
        "linear",
    ])
    .fails(1, &["K = 6561", "operations", "--start auto or nominal"]);
}

/// URDF-native rows (six unknowns a joint) of a 7-joint arm behind a rail: `basis` at the
/// defaults, proven stage by stage (issue 48, build item 5: the direct expansion would pass
/// 8·10⁶ terms; from span-equivalent links before session 32), the same `K` and identifiable count as the DH import of the same URDF;
/// and the linear method on that basis, its `c(p)` from the factored kernel, fits as well as
/// the parameter-space fit.
#[test]
fn urdf_native_rows_of_seven_joints_have_their_basis_and_linear_fit_at_the_defaults() {
    let dir = crate::util::scratch("urdf-native-seven");
    let import = |convention: &str| {
        crate::util::import_rail_chain(&dir, &format!("{convention}.yaml"), convention)
    };
    let (urdf_spec, dh_spec) = (import("urdf"), import("dh"));
    let basis = |spec: &std::path::Path| {
        crate::util::lincal(&["basis", spec.to_str().unwrap(), "--format", "json"])
            .ok()
            .json()
    };
    let (u, d) = (basis(&urdf_spec), basis(&dh_spec));
    assert_eq!(u["basis_size"], d["basis_size"]);
    assert_eq!(u["basis"], d["basis"]);
    assert_eq!(u["identifiable_count"], 29);
    assert_eq!(d["identifiable_count"], 29);
    assert_eq!(u["generalized_params"].as_array().map(Vec::len), Some(0));
    // Session 32: the products of joint functions that can arise (the rail's `q` never
    // multiplies the joints after it), proven stage by stage (from span-equivalent links
    // before).
    let warnings = u["warnings"].to_string();
    assert!(warnings.contains("that can arise (of the"), "{warnings}");
    let spec = urdf_spec.to_str().unwrap();
    let truth = dir.join("truth.yaml");
    let csv = crate::util::simulate(spec, 1200, 4, ["--noise-measure", "1e-5"], &truth);
    let data = crate::util::write(&dir, "d.csv", &csv);
    let fit = |start: &str| {
        crate::util::lincal(&[
            "calibrate",
            spec,
            data.to_str().unwrap(),
            "--start",
            start,
            "--format",
            "json",
        ])
        .ok()
        .json()
    };
    let (linear, nominal) = (fit("linear"), fit("nominal"));
    assert_eq!(linear["method"], "linear");
    assert_eq!(linear["rank"], u["basis_size"]);
    let rms = |r: &serde_json::Value| r["residual_rms"].as_f64().unwrap();
    assert!(
        rms(&linear) < 1.02 * rms(&nominal),
        "{} vs {}",
        rms(&linear),
        rms(&nominal)
    );
    assert!(rms(&linear) < 2e-5);
}
