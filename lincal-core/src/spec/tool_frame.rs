//! The tool frame `tool: {x, y, z, roll, pitch, yaw}`: what validation says about it (a
//! frame is 3-D; its rotation is seen only by a `measured_pose` constraint).

use super::{ParamRole, Slot, Spec};

/// The tool's slots with their roles and field paths: `tool[i]` for a tool point, `tool.x`
/// … `tool.yaw` for a frame (its angles are angle slots).
pub(super) fn tool_slots(spec: &Spec) -> Vec<(&Slot, ParamRole, String)> {
    match &spec.tool_rotation {
        None => spec
            .tool
            .iter()
            .enumerate()
            .map(|(i, s)| (s, ParamRole::Length, format!("tool[{i}]")))
            .collect(),
        Some(rot) => {
            let lengths = spec.tool.iter().zip(["x", "y", "z"]);
            let angles = rot.iter().zip(["roll", "pitch", "yaw"]);
            lengths
                .map(|(s, k)| (s, ParamRole::Length, format!("tool.{k}")))
                .chain(angles.map(|(s, k)| (s, ParamRole::Angle, format!("tool.{k}"))))
                .collect()
        }
    }
}

/// The problems of `spec`'s tool frame, `(field, message)` each: a frame in dim 2, and,
/// unless the spec measures the pose (or its constraint was `refused` by the loader, so may
/// have been a `measured_pose`), a parameter in the rotation no data could estimate.
pub(super) fn problems(spec: &Spec, dim: Option<usize>, refused: bool) -> Vec<(String, String)> {
    let Some(rot) = &spec.tool_rotation else {
        return Vec::new();
    };
    if dim == Some(2) {
        return vec![(
            "tool".into(),
            "a tool frame `{x, y, z, roll, pitch, yaw}` is 3-D: in dim 2 write `tool: [tx, ty]`"
                .into(),
        )];
    }
    if spec.is_measured_pose() || refused {
        return Vec::new();
    }
    rot.iter()
        .zip(["roll", "pitch", "yaw"])
        .filter_map(|(s, k)| match s {
            Slot::Param(name) => Some((
                format!("tool.{k}"),
                format!(
                    "the tool frame's rotation only matters to a `measured_pose` constraint: no \
                     tip position depends on `{name}`, so no data could estimate it (use a \
                     number, or measure the pose)"
                ),
            )),
            Slot::Const(_) => None,
        })
        .collect()
}
