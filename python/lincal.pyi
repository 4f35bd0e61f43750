"""Robot kinematic calibration by the linear generalized-parameter method (Sayeh & Newman),
with numpy arrays in and out.

Every call is a thin wrapper over the Rust crate ``lincal-core``: the same spec loader, solver
and JSON as the ``lincal`` command line. Units are metres and radians everywhere.

Example::

    import lincal
    spec = lincal.Spec.from_yaml("adept_one.yaml")
    sim = lincal.simulate(spec, 200, seed=7, noise_track=30e-6)
    cal = lincal.calibrate(spec, sim.q)
    print(cal.params["a2"]["value"], cal.residual_rms)
"""

from __future__ import annotations

import os
from typing import Any, Dict, List, Literal, Mapping, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "__version__",
    "Error",
    "InputError",
    "SpecError",
    "DataError",
    "DegenerateError",
    "ComputationError",
    "InternalError",
    "Spec",
    "Basis",
    "Calibration",
    "Simulation",
    "Selection",
    "calibrate",
    "simulate",
    "select",
    "DEFAULT_MAX_TERMS",
]

__version__: str
DEFAULT_MAX_TERMS: int
"""Default bound on the terms of any polynomial of the exact expansion."""

_ArrayLike = npt.ArrayLike
_Params = Union[None, "Calibration", Mapping[str, float], Sequence[float], npt.NDArray[np.float64]]
"""Parameter values: None (the nominals), a Calibration, a dict name -> value (estimated
parameters left out take their nominal; known ones may only repeat theirs), or P numbers in
the order of ``Spec.estimated``."""

class Error(Exception):
    """Base of every lincal error.

    ``file``, ``line``, ``column`` (1-based), ``field`` (a field path such as
    ``joints[1].home``, or a data column such as ``q2``) and ``pose`` (0-based row) locate the
    first problem (None when unknown); ``diagnostics`` lists every problem.
    """

    file: Optional[str]
    line: Optional[int]
    column: Optional[int]
    field: Optional[str]
    pose: Optional[int]
    diagnostics: Tuple[Dict[str, Any], ...]

class InputError(Error, ValueError):
    """Bad input (the command line's exit status 2): a spec, array, file or option."""

class SpecError(InputError):
    """A problem in a spec (YAML file, text or dict), with its ``field`` (and ``line``,
    ``column`` for YAML text; None for a dict)."""

class DataError(InputError):
    """A problem in the readings: shape, dtype, NaN or infinite value (``pose`` is the row,
    ``field`` the column, e.g. ``q2``), a constraint index, or a bad CSV cell."""

class DegenerateError(Error, ValueError):
    """Valid input that cannot be calibrated (the command line's exit status 1): too few
    poses, a frozen joint, lost rank, an unreachable constraint."""

class ComputationError(Error, RuntimeError):
    """Valid input whose computation cannot be done: an exact expansion beyond
    ``max_terms``, a numerical failure, an unreadable file (the rest of the exit status 1)."""

class InternalError(Error, RuntimeError):
    """A bug: a panic caught at the boundary (none is expected on any input)."""

@final
class Spec:
    """A robot and its constraint, validated, with its exact symbolic model."""

    @staticmethod
    def from_yaml(path: Union[str, os.PathLike[str]], *, max_terms: Optional[int] = None) -> Spec:
        """Load a spec file (YAML). Raises SpecError naming file, line, column and field;
        ComputationError when the exact expansion would exceed max_terms terms."""
    @staticmethod
    def from_str(text: str, *, max_terms: Optional[int] = None) -> Spec:
        """Parse spec text (YAML). Raises SpecError located in the text."""
    @staticmethod
    def from_dict(d: Mapping[str, Any], *, max_terms: Optional[int] = None) -> Spec:
        """Build a spec from a dict with the YAML schema (through the same loader). Raises
        SpecError with ``field``; ``line`` is None."""
    @property
    def name(self) -> str:
        """The spec's name."""
    @property
    def dim(self) -> int:
        """2 (planar) or 3."""
    @property
    def joint_count(self) -> int:
        """Number of joints n (columns of q)."""
    @property
    def params(self) -> List[str]:
        """Every parameter name, spec order (known ones included)."""
    @property
    def estimated(self) -> List[str]:
        """The estimated parameter names (known ones left out): the order of a vector p."""
    @property
    def nominal(self) -> Dict[str, float]:
        """Nominal value of every parameter."""
    @property
    def known(self) -> List[str]:
        """Parameters declared ``known: true``."""
    @property
    def constraints(self) -> List[str]:
        """The kind of each constraint (``line``, ``plane``, ``measured``, ...)."""
    @property
    def constraint_list(self) -> bool:
        """Whether the spec has a list (``constraints:``): calibrate then needs ``constraint``."""
    @property
    def measured(self) -> bool:
        """Whether a constraint is ``measured`` or ``measured_pose``: calibrate then needs
        ``x``."""
    @property
    def measured_pose(self) -> bool:
        """Whether the constraint is ``measured_pose``: calibrate then needs ``x`` and
        ``quaternion`` or ``rotvec``."""
    def basis(self) -> Basis:
        """The symbolic result (``lincal basis --format json``)."""
    def tip(self, q: _ArrayLike, params: _Params = None) -> npt.NDArray[np.float64]:
        """Forward kinematics: the (N, dim) tips of the (N, n) readings q at params."""
    def tool_pose(
        self, q: _ArrayLike, params: _Params = None
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The tool frame of the (N, n) readings q at params (3-D specs): origins (N, 3) and
        unit quaternions (N, 4), scalar first (qw, qx, qy, qz; qw >= 0), what ``lincal
        predict`` prints for a ``measured_pose`` spec. Raises InputError for a planar spec."""
    def residuals(
        self,
        q: _ArrayLike,
        params: _Params = None,
        *,
        x: Optional[_ArrayLike] = None,
        quaternion: Optional[_ArrayLike] = None,
        rotvec: Optional[_ArrayLike] = None,
        constraint: Optional[_ArrayLike] = None,
    ) -> npt.NDArray[np.float64]:
        """(N,) geometric distance of each tip from its constraint at params (metres);
        params None: the nominals (the residuals before calibration). For a
        ``measured_pose`` spec, each pose's position error."""
    def evaluate(
        self,
        q: _ArrayLike,
        params: _Params = None,
        *,
        x: Optional[_ArrayLike] = None,
        quaternion: Optional[_ArrayLike] = None,
        rotvec: Optional[_ArrayLike] = None,
        constraint: Optional[_ArrayLike] = None,
    ) -> Dict[str, Any]:
        """Judge params on held-out poses beside the nominals, as ``lincal evaluate``: unknown
        constraint values refitted to the tips; per constraint residual RMS and max, points'
        spread and mean, per pair of points the distance between the means; with a
        Calibration as params, "beyond_ranges": {poses, of, farthest}, the poses with a joint
        beyond the range its data spanned (by more than 0.05 rad or 0.01 m)."""
    def read_csv(
        self,
        path: Union[str, os.PathLike[str], Sequence[Union[str, os.PathLike[str]]]],
        *,
        angles: Literal["rad", "deg", "auto"] = "auto",
    ) -> Dict[str, Any]:
        """Read a data CSV, or several as ``lincal calibrate`` reads them (a spec with a list of
        constraints: one file per constraint, in order; one constraint: the files joined):
        {"q": (N, n), "x": (N, dim) or None, "constraint": (N,) or None, "lines": (N,)}, and
        "quaternion": (N, 4) for a ``measured_pose`` spec (whichever orientation form the file
        holds). A spec imported from a URDF takes the URDF's joint names as column headers.
        angles: the unit of revolute readings ("deg": converted to radians; "auto": radians,
        readings that look like degrees raise DataError). Raises DataError naming file, line
        and column."""

@final
class Basis:
    """What ``lincal basis SPEC --format json`` prints."""

    @property
    def basis_size(self) -> int:
        """K, the size of the column-reduced basis."""
    @property
    def basis(self) -> List[str]:
        """The K basis functions as strings."""
    @property
    def naive_size(self) -> int:
        """Distinct monomials before any reduction."""
    @property
    def identifiable_count(self) -> int:
        """Independent parameter combinations the constraint determines."""
    @property
    def identifiable(self) -> List[str]:
        """Names identifiable on their own."""
    @property
    def unidentifiable(self) -> List[str]:
        """Names not identifiable on their own."""
    @property
    def gauge(self) -> List[Dict[str, float]]:
        """Directions the data cannot see, each {param: coefficient}."""
    @property
    def held(self) -> List[str]:
        """Parameters the gauge rule holds at their nominal."""
    @property
    def params(self) -> List[str]:
        """The estimated parameter names."""
    def to_dict(self) -> Dict[str, Any]:
        """Every field of the JSON."""
    def to_json(self) -> str:
        """The JSON text the command line prints (without the final newline)."""

@final
class Calibration:
    """The result of ``calibrate``; ``to_dict()``/``to_json()`` are the command line's JSON."""

    @property
    def params(self) -> Dict[str, Dict[str, Any]]:
        """name -> {value, std, identifiable, known, held}, every parameter, spec order."""
    @property
    def values(self) -> Dict[str, float]:
        """name -> calibrated value, every parameter."""
    @property
    def residuals(self) -> npt.NDArray[np.float64]:
        """(N,) read-only: distance of each calibrated tip from the calibrated constraint, m
        (for ``measured_pose``, each pose's position error)."""
    @property
    def residual_rms(self) -> float:
        """RMS of the residuals, metres (for ``measured_pose``, of the position error)."""
    @property
    def orientation_rms(self) -> Optional[float]:
        """For ``measured_pose``: RMS orientation error ``|log(R_measured^T R)|``, radians;
        None otherwise."""
    @property
    def orientation_residuals(self) -> Optional[npt.NDArray[np.float64]]:
        """For ``measured_pose``: (N,) read-only orientation error of each pose, radians;
        None otherwise."""
    @property
    def pose_noise(self) -> Optional[Dict[str, Any]]:
        """For ``measured_pose``: {position_std (m), orientation_std (rad), weight (m/rad),
        held_ratio (the levels' ratio when the weight is held at a bound of 1e-4..1e4, else
        None), estimated (levels estimated from the data), rounds}; None otherwise."""
    @property
    def basis_size(self) -> int:
        """K."""
    @property
    def rank(self) -> int:
        """Numerical rank of the data matrix."""
    @property
    def identifiable_count(self) -> int:
        """Independent identifiable combinations."""
    @property
    def poses(self) -> int:
        """Poses used."""
    @property
    def method(self) -> str:
        """``linear``, ``linear+refine`` or ``nominal+refine``."""
    @property
    def start(self) -> str:
        """``linear`` or ``nominal``."""
    @property
    def condition(self) -> Optional[float]:
        """Condition number of the gauge-fixed Jacobian at the estimate."""
    @property
    def warnings(self) -> List[str]:
        """Human-readable warnings."""
    @property
    def worst_poses(self) -> List[Dict[str, Any]]:
        """The poses farthest from their constraint: {pose, line, residual, standardized},
        the 10 of largest standardized residual (z; None below 10 poses or on exact data),
        listed in descending residual."""
    @property
    def prior(self) -> Dict[str, Any]:
        """What the prior did: {weight, length_tolerance, angle_tolerance, shape, applied,
        sigma, weak, selection} (selection: how the data chose its strength, the default:
        {rule, tolerance, start, grouping, folds, curve, ard_rms, lack_of_fit, directions, held};
        rule is "scale", "ard" or "residual")."""
    @property
    def rejected(self) -> List[Dict[str, Any]]:
        """Poses dropped by reject_outliers: {pose, line, residual, standardized}."""
    def to_dict(self) -> Dict[str, Any]:
        """Every field of ``lincal calibrate --format json``."""
    def to_json(self) -> str:
        """That JSON text (without the final newline)."""

@final
class Simulation:
    """A simulated data set."""

    @property
    def q(self) -> npt.NDArray[np.float64]:
        """Recorded readings (encoder noise included), (N, n)."""
    @property
    def true_q(self) -> npt.NDArray[np.float64]:
        """True readings, (N, n)."""
    @property
    def x(self) -> Optional[npt.NDArray[np.float64]]:
        """Measured tips (N, dim) for a measured constraint, else None."""
    @property
    def quaternion(self) -> Optional[npt.NDArray[np.float64]]:
        """Measured orientations (N, 4), unit quaternions scalar first, for a
        ``measured_pose`` spec, else None."""
    @property
    def constraint(self) -> Optional[npt.NDArray[np.int64]]:
        """Constraint index (N,) for a spec with a list, else None."""
    @property
    def truth(self) -> Dict[str, float]:
        """True value of every estimated parameter."""
    def data(self) -> Dict[str, Any]:
        """``calibrate`` keyword arguments: q, and x / quaternion / constraint when needed."""

@final
class Selection:
    """The poses ``select`` chose and what they are worth (the figures of ``lincal select
    --format json``)."""

    @property
    def indices(self) -> npt.NDArray[np.int64]:
        """Chosen poses' indices into the candidates (or the generated pool), (N,), in
        visiting order."""
    @property
    def q(self) -> npt.NDArray[np.float64]:
        """Chosen poses' joint readings, (N, n), in visiting order."""
    @property
    def constraint(self) -> Optional[npt.NDArray[np.int64]]:
        """Chosen poses' constraint indices (N,) for a spec with a list, else None."""
    @property
    def params(self) -> Dict[str, Dict[str, Optional[float]]]:
        """Per free parameter: {"std": predicted std with the chosen poses, "random_std":
        median over random picks of as many pool poses}."""
    @property
    def tip_rms(self) -> Optional[float]:
        """Predicted RMS tip error over the workspace with the chosen poses, metres."""
    @property
    def random_tip_rms(self) -> Optional[float]:
        """The same for random picks (median), metres."""
    @property
    def condition(self) -> Optional[float]:
        """Condition number of the chosen poses' whitened Jacobian (columns scaled)."""
    @property
    def worth(self) -> Optional[int]:
        """How many random pool poses match the chosen ones in D (median); None when the
        pool holds too few."""
    @property
    def efficiency_bound(self) -> Optional[float]:
        """Kiefer-Wolfowitz lower bound on the D-efficiency among sets of as many pool
        poses."""
    @property
    def log_det(self) -> Optional[float]:
        """D criterion of the chosen poses: mean over the draws of log det(information)."""
    @property
    def random_log_det(self) -> Optional[float]:
        """D criterion of random picks (median)."""
    @property
    def held(self) -> List[str]:
        """Parameters held by the gauge rule: no pose choice improves them."""
    @property
    def dropped(self) -> List[Dict[str, Any]]:
        """Candidates off their nominal constraint: dicts {candidate, line, residual}."""
    @property
    def below_basis_size(self) -> bool:
        """Whether the count is below the linear method's basis size K (proved from samples,
        or read from a K cached by calibrate, whose sketch errs with probability at most
        about 2e-9)."""
    @property
    def notes(self) -> List[str]:
        """Notes on the choice, one sentence each."""
    @property
    def sigma(self) -> Dict[str, float]:
        """Standard deviations the residuals were whitened by: constraint, measured,
        orientation, encoder."""
    @property
    def prior(self) -> Optional[Dict[str, Any]]:
        """The calibration's prior the plan was made for: {shape, weight, length_tolerance,
        angle_tolerance, applied, weak}; None when off."""
    def summary(self) -> str:
        """The summary ``lincal select`` prints on stderr."""
    def to_dict(self) -> Dict[str, Any]:
        """Every field, as ``lincal select --format json`` prints it (``line`` None)."""
    def to_json(self) -> str:
        """The JSON text of ``to_dict()``."""

@final
class Compensation:
    """Compensated targets (``lincal compensate``), one row per target in input order."""

    @property
    def q(self) -> npt.NDArray[np.float64]:
        """(N, n) compensated joints q' (a failed row: the solve's last point, not to be sent)."""
    @property
    def x(self) -> npt.NDArray[np.float64]:
        """(N, dim) filtered targets FK_nominal(q'), for a controller's Cartesian targets."""
    @property
    def quaternion(self) -> Optional[npt.NDArray[np.float64]]:
        """(N, 4) the filtered targets' orientation (qw, qx, qy, qz) for a frame tool; None
        otherwise."""
    @property
    def correction(self) -> npt.NDArray[np.float64]:
        """(N,) |q' - q0| (radians; metres for prismatic joints)."""
    @property
    def residual(self) -> npt.NDArray[np.float64]:
        """(N,) remaining position error, metres."""
    @property
    def orientation_residual(self) -> npt.NDArray[np.float64]:
        """(N,) remaining orientation error of pose targets, radians (0 otherwise)."""
    @property
    def sigma(self) -> npt.NDArray[np.float64]:
        """(N,) predicted tool position uncertainty at q', metres (0 without a covariance)."""
    @property
    def status(self) -> List[str]:
        """Each target's status: ok, limit, singular, branch or diverged."""
    @property
    def failed(self) -> int:
        """Targets that did not end ok."""
    def summary(self) -> Dict[str, Any]:
        """The summary ``lincal compensate --format json`` prints (line = row index)."""
    def __len__(self) -> int: ...

def compensate(
    spec: Spec,
    params: _Params,
    q: _ArrayLike,
    *,
    x: Optional[_ArrayLike] = None,
    quaternion: Optional[_ArrayLike] = None,
    rotvec: Optional[_ArrayLike] = None,
    intended_base: Optional[str] = None,
) -> Compensation:
    """Compensates targets for a controller that keeps its nominal model: joint targets q
    (the intended tool is the nominal model's; with ``intended_base="calibrated"`` the nominal
    arm placed by the calibrated ``base:``, for a laser tracker's frame; ``None`` is
    ``"nominal"`` with a UserWarning when the calibrated base moves the intended tools by
    more than 1 cm), or Cartesian targets x (with an orientation for a frame tool) seeded by
    q. Failed targets are flagged in ``status``, not raised."""

def calibrate(
    spec: Spec,
    q: _ArrayLike,
    *,
    x: Optional[_ArrayLike] = None,
    quaternion: Optional[_ArrayLike] = None,
    rotvec: Optional[_ArrayLike] = None,
    constraint: Optional[_ArrayLike] = None,
    refine: bool = False,
    robust: Optional[Literal["huber", "cauchy"]] = None,
    start: Literal["auto", "linear", "nominal"] = "auto",
    reject_outliers: bool = False,
    lines: Optional[_ArrayLike] = None,
    prior: Union[bool, Literal["frames", "on", "params", "off"], None] = None,
    prior_weight: Optional[float] = None,
    tolerance_length: Optional[float] = None,
    tolerance_angle: Optional[float] = None,
) -> Calibration:
    """Calibrate spec on the (N, n) readings q, as ``lincal calibrate`` does.

    x: (N, dim) measured tips (``measured``, ``measured_pose``); for ``measured_pose`` the
    measured orientations too, as ``quaternion`` (N, 4: unit, scalar first, qw, qx, qy, qz)
    or ``rotvec`` (N, 3: rotation vectors, radians), one form only.

    prior: the weak-direction prior, ``None``/``True``/``"frames"`` (each joint's mounting
    misplaced by a small rigid motion, the default), ``"params"`` (each arm parameter on its
    own) or ``False``/``"off"``; by default its strength is chosen from the data (grouped
    cross-validation, docs/03-calibrating.md, *How large*). Overrides: prior_weight (1e-12..1e6), MUKCa's
    relative weight against the mean squared residual per pose, tolerances sigma/sqrt(N*w);
    or fixed tolerances, tolerance_length (m), tolerance_angle (rad), each 1e-9..1e3 (the
    other 0.01 when one is left out; not together with prior_weight).

    Raises DataError for a bad array (naming argument, row and column: NaN, a non-unit
    quaternion, both orientation forms), DegenerateError when the poses cannot determine the
    parameters.
    """

def simulate(
    spec: Spec,
    n: int,
    *,
    seed: int = 1,
    truth: Union[None, str, os.PathLike[str], _Params] = None,
    noise_track: float = 0.0,
    noise_encoder: float = 0.0,
    noise_measure: float = 0.0,
    noise_orientation: float = 0.0,
) -> Simulation:
    """Simulate n poses whose true tips lie on the true constraint (as ``lincal simulate``)."""

def select(
    spec: Spec,
    n: int,
    *,
    candidates: Optional[_ArrayLike] = None,
    constraint: Optional[_ArrayLike] = None,
    pool: Optional[int] = None,
    seed: int = 1,
    given: Optional[_ArrayLike] = None,
    given_constraint: Optional[_ArrayLike] = None,
    criterion: Literal["d", "D", "tip"] = "d",
    draws: int = 3,
    noise_track: float = 0.0,
    noise_encoder: float = 0.0,
    noise_measure: float = 0.0,
    noise_orientation: float = 0.0,
    max_off: float = 0.05,
    prior: Union[bool, Literal["frames", "on", "params", "off"], None] = None,
    prior_weight: Optional[float] = None,
    tolerance_length: Optional[float] = None,
    tolerance_angle: Optional[float] = None,
) -> Selection:
    """Choose the n poses worth measuring, as ``lincal select`` does.

    candidates: (M, n) joint readings to choose from (no measured tips needed), with
    constraint (M,) for a spec with a list; or pool: M poses projected onto the nominal
    constraint. given: (G, n) readings already measured (given_constraint for a list).
    criterion: "d" (D-optimality) or "tip" (least predicted tip error). noise_encoder adds
    σ²(∂g/∂q)(∂g/∂q)ᵀ to each pose's residual covariance. prior, prior_weight,
    tolerance_length, tolerance_angle: the weak-direction prior calibrate will use (as in
    ``calibrate``); when the data alone would leave a parameter weak, its information counts
    in every design.

    Raises InputError (a ValueError) naming the argument, DataError for a bad array,
    DegenerateError when n poses cannot see every free parameter.
    """
