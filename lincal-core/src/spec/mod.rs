//! The calibration spec: a serial chain in Denavit-Hartenberg form, its parameters and the
//! constraint(s) the tool tip is held on, exactly as `shared/interface.md` defines them.
//!
//! Data flows one way: [`load`] turns YAML into a [`Spec`] (every error located), then the
//! symbolic engine ([`crate::symbolic`]) expands it. Slots keep numbers exact ([`Exact`]), so
//! `cos(pi/2)` is exactly 0 and the basis of a PUMA is the PUMA's, not a generic arm's.

pub mod chain;
pub mod expr;
pub mod kinematics;
pub mod load;
mod locate;
pub mod node;
mod plane_normal;
pub mod structure;
mod tool_frame;
pub mod urdf_record;
pub mod validate;
pub mod write;

pub use expr::Exact;
pub use load::{from_tree, from_yaml_file, from_yaml_str, suggest};
pub use locate::{join_index, join_key, parent as parent_field};
pub use validate::validate;

/// Denavit-Hartenberg convention of the joint table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convention {
    /// Standard DH: `A_i = Rz(θ_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)`.
    Dh,
    /// Modified DH (Craig): `A_i = Rx(α_i)·Tx(a_i)·Rz(θ_i)·Tz(d_i)`.
    Mdh,
    /// URDF-native: each joint's origin as a URDF writes it, then its motion about (or
    /// along) its own z axis, `A_i = Tr(x_i, y_i, z_i)·Rz(yaw_i)·Ry(pitch_i)·Rx(roll_i)·Rz(θ_i)·Tz(d_i)`
    /// ([`Joint::origin`]): six numbers per joint, any of them unknown, the redundant ones
    /// held by the exact gauge rule. After the origin a row is a modified-DH row with
    /// `a = α = β = 0`.
    Urdf,
}

/// The form of the DH row that follows a joint's [`Joint::origin`] ([`Convention::row`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowForm {
    /// `Rz(θ)·Tz(d)·Tx(a)·Rx(α)·Ry(β)`.
    Dh,
    /// `Rx(α)·Ry(β)·Tx(a)·Rz(θ)·Tz(d)`.
    Mdh,
}

impl Convention {
    /// The DH row that follows a joint's [`Joint::origin`]: standard for [`Convention::Dh`],
    /// modified otherwise ([`Convention::Urdf`]'s rows have `a = α = β = 0`).
    #[must_use]
    pub fn row(self) -> RowForm {
        match self {
            Convention::Dh => RowForm::Dh,
            Convention::Mdh | Convention::Urdf => RowForm::Mdh,
        }
    }

    /// The name the spec's `convention:` gives it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Convention::Dh => "dh",
            Convention::Mdh => "mdh",
            Convention::Urdf => "urdf",
        }
    }
}

/// What a joint reading moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// `θ_i = q_i − home_i`.
    Revolute,
    /// `d_i = q_i + offset_i`, with a fixed angle `theta`.
    Prismatic,
}

/// One slot of the spec: an exact number or a parameter name.
#[derive(Clone, Debug, PartialEq)]
pub enum Slot {
    /// An exact value `r + s·π` (see [`Exact`]).
    Const(Exact),
    /// A parameter, by name (an entry of [`Spec::params`]).
    Param(String),
}

impl Slot {
    /// The zero slot (a missing DH entry).
    #[must_use]
    pub fn zero() -> Self {
        Slot::Const(Exact::zero())
    }

    /// The parameter name, if this slot is one.
    #[must_use]
    pub fn param(&self) -> Option<&str> {
        match self {
            Slot::Param(n) => Some(n),
            Slot::Const(_) => None,
        }
    }
}

/// One row of the DH table.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// Link length `a_i` (metres).
    pub a: Slot,
    /// Link twist `α_i` (radians).
    pub alpha: Slot,
    /// Hayati's tilt `β_i` (radians, 0 when absent): a turn about the link's y axis, right
    /// after the twist (`Rx(α)·Ry(β)·Tx(a)·…` in modified DH, `…·Rx(α)·Ry(β)` last in DH). At
    /// parallel consecutive axes the DH table cannot tilt one within their common plane
    /// (the common normal runs off to infinity); `β` can, with the redundant `d` held.
    pub beta: Slot,
    /// Link offset `d_i` (metres); for a prismatic joint use `offset` instead.
    pub d: Slot,
    /// Home offset of a revolute joint: `θ_i = q_i − home_i` (zero for prismatic joints).
    pub home: Slot,
    /// Fixed joint angle of a prismatic joint (zero for revolute joints).
    pub theta: Slot,
    /// Offset of a prismatic joint: `d_i = q_i + offset_i` (zero for revolute joints).
    pub offset: Slot,
    /// Optional joint limits `[min, max]` on the reading `q_i`.
    pub limits: Option<[f64; 2]>,
    /// The joint's origin in the previous joint's frame, `Tr(x, y, z)·Rz(yaw)·Ry(pitch)·Rx(roll)`
    /// before the row (as a URDF `<origin xyz rpy>`): only in [`Convention::Urdf`], the
    /// identity (every slot 0) otherwise.
    pub origin: Base,
}

impl Joint {
    /// The slot a spec key names (`a`, `alpha`, `beta`, `d`, `home`, `theta`, `offset`, and
    /// the origin's `x`, `y`, `z`, `roll`, `pitch`, `yaw`), for the loaders of both spec
    /// sources (YAML and derive attributes).
    pub fn slot_mut(&mut self, key: &str) -> Option<&mut Slot> {
        if let Some(s) = self.origin.slot_mut(key) {
            return Some(s);
        }
        match key {
            "a" => Some(&mut self.a),
            "alpha" => Some(&mut self.alpha),
            "beta" => Some(&mut self.beta),
            "d" => Some(&mut self.d),
            "home" => Some(&mut self.home),
            "theta" => Some(&mut self.theta),
            "offset" => Some(&mut self.offset),
            _ => None,
        }
    }
}

/// A rigid transform `Tr(x, y, z)·Rz(yaw)·Ry(pitch)·Rx(roll)`: the optional base transform
/// `B`, and a joint's origin in [`Convention::Urdf`].
#[derive(Clone, Debug, PartialEq)]
pub struct Base {
    /// Translation x.
    pub x: Slot,
    /// Translation y.
    pub y: Slot,
    /// Translation z.
    pub z: Slot,
    /// Rotation about x (applied first).
    pub roll: Slot,
    /// Rotation about y.
    pub pitch: Slot,
    /// Rotation about z (applied last).
    pub yaw: Slot,
}

impl Base {
    /// Whether every slot is the constant 0 (the identity).
    #[must_use]
    pub fn is_identity(&self) -> bool {
        self.slots().iter().all(|(_, s)| **s == Slot::zero())
    }

    /// The slots with their keys, translation first: `x`, `y`, `z`, `roll`, `pitch`, `yaw`.
    #[must_use]
    pub fn slots(&self) -> [(&'static str, &Slot); 6] {
        [
            ("x", &self.x),
            ("y", &self.y),
            ("z", &self.z),
            ("roll", &self.roll),
            ("pitch", &self.pitch),
            ("yaw", &self.yaw),
        ]
    }

    /// The identity transform (every slot 0).
    #[must_use]
    pub fn zero() -> Self {
        Base {
            x: Slot::zero(),
            y: Slot::zero(),
            z: Slot::zero(),
            roll: Slot::zero(),
            pitch: Slot::zero(),
            yaw: Slot::zero(),
        }
    }

    /// The slot a spec key names (`x`, `y`, `z`, `roll`, `pitch`, `yaw`).
    pub fn slot_mut(&mut self, key: &str) -> Option<&mut Slot> {
        match key {
            "x" => Some(&mut self.x),
            "y" => Some(&mut self.y),
            "z" => Some(&mut self.z),
            "roll" => Some(&mut self.roll),
            "pitch" => Some(&mut self.pitch),
            "yaw" => Some(&mut self.yaw),
            _ => None,
        }
    }
}

/// How a parameter enters the kinematics, which decides its symbolic representation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamRole {
    /// Used in angle slots (`home`, `alpha`, `theta`, base `roll/pitch/yaw`): enters through
    /// `cos p`, `sin p`.
    Angle,
    /// Used in every other slot: enters polynomially.
    Length,
}

/// One entry of `params`.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// The name used in slots.
    pub name: String,
    /// Nominal value (a number or an exact expression in the YAML).
    pub nominal: Exact,
    /// Known: fixed at the nominal, not estimated.
    pub known: bool,
    /// Angle or length, from the slots that use it (set by validation).
    pub role: ParamRole,
}

/// One constraint the tool tip is held on; `b` is always the paper's form `b·x + 1 = 0`.
// Fixed-size arrays keep the shapes in the type; a spec holds a handful of constraints, so the
// size of the largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Constraint {
    /// `x = p` (pinned tip), `dim` entries.
    Point {
        /// The point.
        p: Vec<Slot>,
    },
    /// 2-D line `b·x + 1 = 0`.
    Line2 {
        /// Line coefficients `[b1, b2]`.
        b: [Slot; 2],
    },
    /// 3-D line as two planes `b₁·x + 1 = 0`, `b₂·x + 1 = 0`.
    Line3 {
        /// The two planes' coefficients.
        planes: [[Slot; 3]; 2],
    },
    /// Plane `b·x + 1 = 0`.
    Plane {
        /// Plane coefficients `[b1, b2, b3]`.
        b: [Slot; 3],
    },
    /// Plane by normal and offset, `n·x = d` (dim 3): `plane: {normal: [n1, n2, n3], offset: d}`.
    ///
    /// Unlike `b·x + 1 = 0` it holds planes through the origin (`d = 0`). The normal need not
    /// be of unit length: the geometric residual is `(n·x − d)/‖n‖`, so `(λn, λd)` for any
    /// `λ ≠ 0` is the same plane (an unknown normal has this scale as a gauge direction).
    PlaneNormal {
        /// The normal `[n1, n2, n3]` (any nonzero length).
        normal: [Slot; 3],
        /// The offset `d` (the signed distance from the origin times `‖n‖`).
        offset: Slot,
    },
    /// Circle `‖x − c‖ = r` (dim 2).
    Circle {
        /// Center, 2 entries.
        center: [Slot; 2],
        /// Radius.
        radius: Slot,
    },
    /// Sphere `‖x − c‖ = r` (dim 3).
    Sphere {
        /// Center, 3 entries.
        center: [Slot; 3],
        /// Radius.
        radius: Slot,
    },
    /// Quadric `xᵀA x + bᵀx + 1 = 0`, `A` symmetric `dim × dim`, `b` of `dim` entries.
    Quadric {
        /// The symmetric matrix, row-major `dim × dim`.
        a: Vec<Vec<Slot>>,
        /// The linear part.
        b: Vec<Slot>,
    },
    /// The tip position is measured (data columns `x, y(, z)`).
    Measured,
    /// The tool frame's position and orientation are measured (dim 3; data columns `x, y, z`
    /// and `qw, qx, qy, qz` or `rx, ry, rz`). The noise levels, when the spec states them,
    /// weigh the orientation residual against the position residual; otherwise they are
    /// estimated from the data (variance components).
    MeasuredPose {
        /// Standard deviation of each measured position coordinate (metres), if stated.
        position_std: Option<f64>,
        /// Standard deviation of each measured orientation component (radians), if stated.
        orientation_std: Option<f64>,
    },
}

impl Constraint {
    /// The interface's name of this kind (`point`, `line`, `plane`, ...).
    #[must_use]
    pub fn kind_name(&self) -> &'static str {
        match self {
            Constraint::Point { .. } => "point",
            Constraint::Line2 { .. } | Constraint::Line3 { .. } => "line",
            Constraint::Plane { .. } | Constraint::PlaneNormal { .. } => "plane",
            Constraint::Circle { .. } => "circle",
            Constraint::Sphere { .. } => "sphere",
            Constraint::Quadric { .. } => "quadric",
            Constraint::Measured => "measured",
            Constraint::MeasuredPose { .. } => "measured_pose",
        }
    }

    /// The slots of this constraint in the canonical order of
    /// [`crate::model::geometry::ConstraintKind`] values (point: p; line2: b; line3: plane 1 then
    /// plane 2; plane: b; plane by normal: normal then offset; circle/sphere: center then radius; quadric: A row-major then b).
    #[must_use]
    pub fn slots(&self) -> Vec<&Slot> {
        match self {
            Constraint::Point { p } => p.iter().collect(),
            Constraint::Line2 { b } => b.iter().collect(),
            Constraint::Line3 { planes } => planes.iter().flatten().collect(),
            Constraint::Plane { b } => b.iter().collect(),
            Constraint::PlaneNormal { normal, offset } => {
                normal.iter().chain(core::iter::once(offset)).collect()
            }
            Constraint::Circle { center, radius } => {
                center.iter().chain(core::iter::once(radius)).collect()
            }
            Constraint::Sphere { center, radius } => {
                center.iter().chain(core::iter::once(radius)).collect()
            }
            Constraint::Quadric { a, b } => a.iter().flatten().chain(b.iter()).collect(),
            Constraint::Measured | Constraint::MeasuredPose { .. } => Vec::new(),
        }
    }

    /// The geometric kind used by the solver.
    #[must_use]
    pub fn geometry_kind(&self) -> crate::model::geometry::ConstraintKind {
        use crate::model::geometry::ConstraintKind as K;
        match self {
            Constraint::Point { .. } => K::Point,
            Constraint::Line2 { .. } => K::Line2,
            Constraint::Line3 { .. } => K::Line3,
            Constraint::Plane { .. } => K::Plane,
            Constraint::PlaneNormal { .. } => K::PlaneNormal,
            Constraint::Circle { .. } => K::Circle,
            Constraint::Sphere { .. } => K::Sphere,
            Constraint::Quadric { .. } => K::Quadric,
            Constraint::Measured => K::Measured,
            Constraint::MeasuredPose { .. } => K::MeasuredPose,
        }
    }
}

/// A whole, validated calibration spec.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    /// Identifier, used for generated names.
    pub name: String,
    /// Optional free text.
    pub description: Option<String>,
    /// 2 (planar: x, y of the tip) or 3.
    pub dim: usize,
    /// DH convention of the joint table.
    pub convention: Convention,
    /// Joints, base to tip.
    pub joints: Vec<Joint>,
    /// Tip point in the last frame, `dim` entries (for a tool frame, its `x, y, z`).
    pub tool: Vec<Slot>,
    /// The tool frame's rotation `[roll, pitch, yaw]` when `tool:` is a frame
    /// `{x, y, z, roll, pitch, yaw}` (dim 3): the tool frame is `Tr(tool)·Rz(yaw)·Ry(pitch)·Rx(roll)`
    /// in the last link's frame, as `base`. `None` for `tool: [..]` (the last frame's axes).
    /// Only a `measured_pose` constraint sees it.
    pub tool_rotation: Option<[Slot; 3]>,
    /// Optional base transform (dim 3; in dim 2 only x, y, yaw may be non-zero).
    pub base: Option<Base>,
    /// Every parameter, in spec order.
    pub params: Vec<Param>,
    /// The constraint(s); one entry for `constraint:`, the list for `constraints:`.
    pub constraints: Vec<Constraint>,
    /// Whether the YAML used `constraints:` (a list): data then has a `constraint` column.
    pub constraint_list: bool,
    /// Relations between constraints of the list (`relations:`): known distances between
    /// centres, parallel planes, parallel planes a known distance apart.
    pub relations: Vec<crate::model::geometry::Relation>,
}

impl Spec {
    /// The parameter with this name.
    #[must_use]
    pub fn param(&self, name: &str) -> Option<&Param> {
        self.params.iter().find(|p| p.name == name)
    }

    /// Whether each joint is prismatic (its reading in metres; revolute: radians), in order.
    #[must_use]
    pub fn prismatic_joints(&self) -> Vec<bool> {
        self.joints
            .iter()
            .map(|j| j.kind == JointKind::Prismatic)
            .collect()
    }

    /// The names of the parameters in the `base:` slots (`x, y, z, roll, pitch, yaw` order):
    /// a tracker's registration, or the arm's mounting in its cell.
    #[must_use]
    pub fn base_params(&self) -> Vec<&str> {
        self.base
            .iter()
            .flat_map(|b| b.slots())
            .filter_map(|(_, s)| s.param())
            .collect()
    }

    /// Names of the estimated (not known) parameters, in spec order: the vector `p`.
    #[must_use]
    pub fn estimated_params(&self) -> Vec<&Param> {
        self.params.iter().filter(|p| !p.known).collect()
    }

    /// Whether the tip is measured (the spec's constraint is `measured` or `measured_pose`).
    #[must_use]
    pub fn is_measured(&self) -> bool {
        self.constraints
            .iter()
            .any(|c| matches!(c, Constraint::Measured | Constraint::MeasuredPose { .. }))
    }

    /// Whether the tool frame's pose is measured (the constraint is `measured_pose`).
    #[must_use]
    pub fn is_measured_pose(&self) -> bool {
        self.constraints
            .iter()
            .any(|c| matches!(c, Constraint::MeasuredPose { .. }))
    }

    /// The stated noise levels of a `measured_pose` constraint: `(position_std,
    /// orientation_std)`, each `None` when the spec leaves it to be estimated.
    #[must_use]
    pub fn pose_noise(&self) -> Option<(Option<f64>, Option<f64>)> {
        self.constraints.iter().find_map(|c| match c {
            Constraint::MeasuredPose {
                position_std,
                orientation_std,
            } => Some((*position_std, *orientation_std)),
            _ => None,
        })
    }
}
