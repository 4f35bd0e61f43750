//! Fuzz target: the CSV reader (`lincal_core::data::Poses::from_csv_reader_with`) on any
//! bytes, under a data layout chosen by the first two bytes.
//!
//! Byte 0: joints `1 + b % 6`, `dim` 2 or 3 (bit 3), a list of constraints (bit 4), only the
//! joint columns required (bit 5), no header row with the standard columns given (bit 6),
//! every pose on one fixed constraint of the list (bit 7). Byte 1: constraints `1 + b % 3`,
//! bits 2-4 whether each is `measured`, bits 5-6 the angles (rad, deg, auto), bit 7 URDF-like
//! joint names (`j1`, …, `x` for the last, which is not taken), the first joint prismatic and
//! the second limited to `[-7, 7]`. The rest is the file. Reading must return poses or a
//! located error: no panic, no hang; the poses it returns are consistent.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lincal_core::data::{Angles, DataLayout, Poses};

fuzz_target!(|data: &[u8]| {
    let (Some(&a), Some(&b)) = (data.first(), data.get(1)) else {
        return;
    };
    let joints = 1 + usize::from(a % 6);
    let dim = if a & 8 != 0 { 3 } else { 2 };
    let count = 1 + usize::from(b % 3);
    let measured: Vec<bool> = (0..count).map(|j| b & (4 << j) != 0).collect();
    let constraint_list = a & 16 != 0 || count > 1;
    let joints_only = a & 32 != 0;
    let columns = (a & 64 != 0).then(|| {
        let mut c: Vec<String> = (1..=joints).map(|i| format!("q{i}")).collect();
        if measured.iter().any(|&m| m) {
            c.extend(["x", "y", "z"][..dim].iter().map(|s| (*s).to_string()));
        }
        if constraint_list {
            c.push("constraint".to_string());
        }
        c
    });
    let constraint = (a & 128 != 0 && constraint_list).then_some(usize::from(b >> 5) % count);
    let layout = DataLayout {
        joints,
        dim,
        measured,
        constraint_list,
        constraint,
        columns,
        joints_only,
        angles: match (b >> 5) & 3 {
            0 => Angles::Rad,
            1 => Angles::Deg,
            _ => Angles::Auto,
        },
        prismatic: (0..joints).map(|i| b & 128 != 0 && i == 0).collect(),
        limits: (0..joints)
            .map(|i| (b & 128 != 0 && i == 1).then_some([-7.0, 7.0]))
            .collect(),
        joint_names: if b & 128 != 0 {
            (1..=joints)
                .map(|i| if i == joints { "x".to_string() } else { format!("j{i}") })
                .collect()
        } else {
            Vec::new()
        },
    };
    match Poses::from_csv_reader_with(&data[2..], Some("fuzz.csv"), &layout) {
        Ok(poses) => {
            let n = poses.len();
            assert_eq!(poses.constraint.len(), n);
            assert_eq!(poses.line.len(), n);
            assert!(poses.constraint.iter().all(|&j| j < count));
            assert!(poses.q.iter().all(|q| q.len() == joints));
            // Only finite readings get through (the reader rejects NaN and inf).
            assert!(poses.q.iter().flatten().all(|v| v.is_finite()));
            if let Some(m) = &poses.measured {
                assert_eq!(m.len(), n);
            }
        }
        Err(e) => {
            assert!(!e.diagnostics().is_empty());
            let _ = e.to_string();
        }
    }
});
