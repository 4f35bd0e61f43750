//! Calibration data: poses read from CSV (see `shared/interface.md`, "Data (CSV)").
//!
//! The file has a header row, then one pose per row. Columns, in any order:
//! - `q1, …, qn`: the joint readings (radians for revolute joints, metres for prismatic ones);
//!   when the spec came from a URDF, a joint's column may be named by its URDF joint name
//!   instead ([`DataLayout::joint_names`]), but not both ways at once;
//! - `x, y(, z)`: the measured tip, required when any constraint of the spec is `measured`;
//! - `constraint`: the 0-based index of the constraint the pose lies on, required exactly when
//!   the spec has a list (`constraints:`).
//!
//! Columns whose name starts with `_` are ignored; any other extra column is an error, and so
//! is a missing one. Lines starting with `#` are comments; blank lines are skipped. Every cell
//! must be a finite number (NaN and infinities are rejected); a bad cell is an
//! [`crate::error::ErrorClass::Input`] error naming the file, the line and
//! the column. Revolute readings may be given in degrees and converted as they are read,
//! and readings that look like degrees refused ([`Angles`], [`DataLayout::angles`]).
//!
//! The parts: [`Rows`] (readings of one width in one vector), [`PoseColumn`] (one integer
//! per pose, stored as runs), [`Poses`] (a data set, and its readers), [`DataLayout`] (what a
//! file holds), [`Angles`] (the unit of revolute readings); the CSV reading itself is private: the expected columns (`layout`), the
//! header row (`header`), the lines of a file (`lines`), its cells (`cells`) and the rows
//! streamed into poses (`reader`).

mod angles;
mod cells;
mod header;
mod layout;
pub(crate) mod lines;
mod pose_column;
mod poses;
mod reader;
mod rows;

pub use angles::{looks_like_degrees, Angles};
pub use cells::MAX_CELL;
pub use layout::DataLayout;
pub use lines::MAX_LINE;
pub use pose_column::PoseColumn;
pub use poses::{DataSource, PoseFiles, Poses};
pub use rows::Rows;
