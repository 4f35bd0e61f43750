//! The CSV loader: layout, comments, errors with file, line and column.

use super::models::{Kind, PlanarArm};
use lincal_core::data::Poses;
use lincal_core::error::ErrorClass;

fn line2() -> PlanarArm {
    PlanarArm::new(2, Kind::Line, vec![0.4, 0.0, 0.3, 0.0, -1.8, 1.0])
}

fn measured2() -> PlanarArm {
    PlanarArm::new(2, Kind::Measured, vec![0.4, 0.0, 0.3, 0.0, 0.0, 0.0])
}

fn err(text: &str, model: &PlanarArm, list: bool) -> String {
    let e = Poses::from_csv_str(text, Some("data.csv"), model, list).expect_err("must fail");
    assert_eq!(e.class(), ErrorClass::Input, "{e}");
    e.to_string()
}

#[test]
fn reads_columns_in_any_order_with_comments_and_blank_lines() {
    let text = "# a comment\nq2,_note,q1\n\n1.0,x,2.0\n  \n# another\n3,y,-4e-1\n";
    let p = Poses::from_csv_str(text, None, &line2(), false).unwrap();
    assert_eq!(p.q, vec![vec![2.0, 1.0], vec![-0.4, 3.0]].into());
    assert_eq!(p.line.to_vec(), vec![4, 7]);
    assert_eq!(p.constraint.to_vec(), vec![0, 0]);
    assert!(p.measured.is_none());
}

#[test]
fn measured_columns() {
    let text = "x,q1,y,q2\n0.5,1,0.25,2\n";
    let p = Poses::from_csv_str(text, None, &measured2(), false).unwrap();
    assert_eq!(p.q, vec![vec![1.0, 2.0]].into());
    assert_eq!(p.measured, Some(vec![vec![0.5, 0.25]].into()));
    let msg = err("q1,q2,x\n1,2,3\n", &measured2(), false);
    assert!(msg.contains("missing column `y`"), "{msg}");
    let msg = err("q1,q2,x,y\n1,2,3,\n", &measured2(), false);
    assert!(msg.contains("data.csv:2") && msg.contains('y'), "{msg}");
}

#[test]
fn bad_cells_name_line_and_column() {
    let msg = err("q1,q2\n1,2\n1,abc\n", &line2(), false);
    assert!(msg.contains("data.csv:3"), "{msg}");
    assert!(msg.contains("`q2`") && msg.contains("abc"), "{msg}");
    for bad in ["NaN", "nan", "inf", "-inf", "1e999"] {
        let msg = err(&format!("q1,q2\n{bad},1\n"), &line2(), false);
        assert!(
            msg.contains("data.csv:2") && msg.contains("`q1`"),
            "{bad}: {msg}"
        );
        assert!(msg.contains("finite"), "{msg}");
    }
    let msg = err("q1,q2\n1,\n", &line2(), false);
    assert!(msg.contains("empty"), "{msg}");
    let msg = err("q1,q2\n1,2,3\n", &line2(), false);
    assert!(
        msg.contains("data.csv:2") && msg.contains("fields"),
        "{msg}"
    );
}

#[test]
fn missing_extra_and_duplicate_columns() {
    let msg = err("q1\n1\n", &line2(), false);
    assert!(msg.contains("missing column `q2`"), "{msg}");
    let msg = err("q1,q2,foo\n1,2,3\n", &line2(), false);
    assert!(msg.contains("unknown column `foo`"), "{msg}");
    let msg = err("q1,q2,q3\n1,2,3\n", &line2(), false);
    assert!(msg.contains("unknown column `q3`"), "{msg}");
    let msg = err("q1,q2,q1\n1,2,3\n", &line2(), false);
    assert!(msg.contains("duplicate column `q1`"), "{msg}");
    // Measured columns are extra when nothing is measured.
    let msg = err("q1,q2,x\n1,2,3\n", &line2(), false);
    assert!(msg.contains("unknown column `x`"), "{msg}");
    let msg = err("", &line2(), false);
    assert!(msg.contains("no header"), "{msg}");
}

#[test]
fn constraint_column() {
    let p = Poses::from_csv_str("constraint,q1,q2\n0,1,2\n", None, &line2(), true).unwrap();
    assert_eq!(p.constraint.to_vec(), vec![0]);
    let msg = err("q1,q2,constraint\n1,2,0\n1,2,1\n", &line2(), true);
    assert!(
        msg.contains("data.csv:3") && msg.contains("out of range"),
        "{msg}"
    );
    let msg = err("q1,q2,constraint\n1,2,-1\n", &line2(), true);
    assert!(msg.contains("constraint index"), "{msg}");
    let msg = err("q1,q2\n1,2\n", &line2(), true);
    assert!(msg.contains("missing column `constraint`"), "{msg}");
    let msg = err("q1,q2,constraint\n1,2,0\n", &line2(), false);
    assert!(msg.contains("unknown column `constraint`"), "{msg}");
}

#[test]
fn file_errors() {
    let e = Poses::from_csv_path(
        std::path::Path::new("/nonexistent/lincal/data.csv"),
        &line2(),
        false,
    )
    .unwrap_err();
    assert_eq!(e.class(), ErrorClass::Input);
    assert!(e.to_string().contains("/nonexistent/lincal/data.csv"));
    let dir = std::env::temp_dir().join(format!("lincal-csv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("d.csv");
    std::fs::write(&path, "q1,q2\n0.1,0.2\n0.3,x\n").unwrap();
    let e = Poses::from_csv_path(&path, &line2(), false).unwrap_err();
    assert!(
        e.to_string().contains(&format!("{}:3", path.display())),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
