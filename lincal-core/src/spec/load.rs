//! YAML → [`Spec`](super::Spec), with located errors. (Being written.)
use super::Spec;
use crate::error::Result;

/// Reads and validates a spec file.
///
/// # Errors
/// Every problem, located.
pub fn from_yaml_file(path: &std::path::Path) -> Result<Spec> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        crate::Error::input(
            crate::error::Location {
                file: Some(path.display().to_string()),
                ..Default::default()
            },
            format!("cannot read: {e}"),
        )
    })?;
    from_yaml_str(&text, Some(&path.display().to_string()))
}

/// Parses and validates spec text; `file` names it in errors.
///
/// # Errors
/// Every problem, located.
pub fn from_yaml_str(_text: &str, _file: Option<&str>) -> Result<Spec> {
    Err(crate::Error::other("not yet"))
}
