"""The mechanism interface, its registry, and what is written once for every mechanism: the
departure solve (unrolled Newton, rootfinder) and the energy torque (docs/mechanisms.md).

A mechanism sits on one joint, owns one or more profiles and names its ports. It describes one
pose symbolically: residuals R(θ, z) = 0 that fix its per-angle unknowns z (the first ones are
the departure angles α_k on its profiles), a closed-form guess of z, and its port displacements
d(θ, z). The energy torque then needs nothing else: its arms are the total derivatives
dd/dθ = ∂d/∂θ + ∂d/∂z dz/dθ + ∂d/∂l dl/dθ, with dz/dθ = −R_z⁻¹R_θ (implicit function theorem)
and dl_k/dθ = √(ρ_k² + ρ_k′²)(α_k) dα_k/dθ for the wrapped lengths l_k (Johnston2023 Eq. 10).
"""
from __future__ import annotations

import warnings
from abc import ABC, abstractmethod
from dataclasses import dataclass
from functools import lru_cache
from importlib.metadata import entry_points
from typing import ClassVar

import casadi as ca
import numpy as np

from ..keys import PART_SIZE, Key, KeyTable
from ..physics.mapped import direct, mapped, on_points
from ..physics.profile import BASES, Basis, profile_function
from ..physics.wrap import arc_length_density, length_function, wound_length

#: The torque model of every mechanism; others are force models a mechanism offers
#: (:attr:`Mechanism.force_models`, :func:`torque_models`).
ENERGY = "energy"

_REGISTRY: dict[str, type] = {}

#: The entry-point group through which an installed package adds mechanisms: each entry names a
#: :class:`Mechanism` subclass (``toy_pulley = "cadcam_toy_pulley:ToyPulley"``), registered the
#: first time the registry is read.
ENTRY_POINT_GROUP = "cadcam.mechanisms"
_plugins_loaded = False


def register(cls):
    """Class decorator: make a mechanism available to specs under ``cls.kind``, once it is
    checked to provide every required hook (:func:`missing_hooks`).

    Raises
    ------
    TypeError
        A hook the class leaves out, named with the group it belongs to.
    ValueError
        Another class registered under the same kind.
    """
    missing = missing_hooks(cls)
    if missing:
        raise TypeError(f"mechanism {cls.__name__} ({cls.kind or 'no kind'}) does not provide "
                        f"{', '.join(missing)}: see the checklist in docs/mechanisms.md")
    if cls.kind in _REGISTRY and _REGISTRY[cls.kind] is not cls:
        raise ValueError(f"a mechanism named {cls.kind!r} is already registered")
    _REGISTRY[cls.kind] = cls
    return cls


def _load_plugins() -> None:
    """Register the mechanisms that installed packages name in :data:`ENTRY_POINT_GROUP`, once;
    one that fails to load is left out with one warning line, so a broken package cannot stop
    every design."""
    global _plugins_loaded
    if _plugins_loaded:
        return
    _plugins_loaded = True
    for entry in entry_points(group=ENTRY_POINT_GROUP):
        try:
            register(entry.load())
        except Exception as exc:  # a third party's import error, or a class that misses hooks
            warnings.warn(f"cadcam: the mechanism {entry.name!r} of an installed package ({entry.value}) is "
                          f"left out: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", stacklevel=2)


def mechanism_class(kind: str):
    """The registered mechanism class named ``kind``; KeyError if there is none."""
    _load_plugins()
    return _REGISTRY[kind]


def mechanism_kinds() -> tuple[str, ...]:
    """Names of the registered mechanisms, those of installed packages included."""
    _load_plugins()
    return tuple(sorted(_REGISTRY))


def built_in_kinds() -> tuple[str, ...]:
    """Names of the mechanisms cadcam itself ships (its folders beside this module): what its
    generated reference and schema describe; a plug-in documents its own."""
    return tuple(k for k in mechanism_kinds() if _REGISTRY[k].__module__.startswith(f"{__package__}."))


def torque_models() -> tuple[str, ...]:
    """``energy`` and every force model a registered mechanism offers."""
    return tuple(dict.fromkeys([ENERGY] + [m for kind in mechanism_kinds() for m in _REGISTRY[kind].force_models]))


def legacy_torque_models() -> dict[str, str]:
    """Old names of force models (a spec's ``friction_model``) → their names today."""
    return {old: new for kind in mechanism_kinds() for old, new in _REGISTRY[kind].legacy_force_models.items()}


@dataclass(frozen=True)
class DesignMethod:
    """A mechanism's own way to make a design without the NLP: its start design
    (:meth:`Mechanism.prepare_start`) is the answer, re-checked like an optimum.

    Attributes
    ----------
    name : str
        The spec's ``[solver] method``.
    title : str
        What made the design, for the result's solver status.
    scope : str
        What it designs, for messages (``"differential pairs for their output laws only"``).
    requirement : str
        What every mechanism of the problem needs for it, for messages.
    sets : tuple of str
        Keys of the mechanism's table that the method chooses itself, so that the spec's values
        are not used (the design page shows them disabled under it).
    """

    name: str
    title: str
    scope: str
    requirement: str
    sets: tuple[str, ...] = ()


def design_methods() -> dict[str, DesignMethod]:
    """The design methods the registered mechanisms offer, by name."""
    return {m.name: m for cls in _REGISTRY.values() for m in cls.methods}


def kinds_in(mechanisms) -> list[type[Mechanism]]:
    """The distinct mechanism classes of ``mechanisms``, in order of first appearance."""
    return list(dict.fromkeys(type(m) for m in mechanisms))


#: Units a per-pose limit may have: its factor to the unit reports show, that unit, and the size
#: [SI] a margin is divided by in the NLP (lengths in millimetres, angles as they are).
LIMIT_UNITS = {"m": (1e3, "mm", 1e-3), "rad": (180 / np.pi, "°", 1.0)}


@dataclass(frozen=True)
class Limit:
    """One per-pose limit of a mechanism, declared once: the NLP's rows, the re-check's margins
    and violations, and the binding sentences all read it.

    Attributes
    ----------
    name : str
        The margin's name (a key of ``metrics.margins.mechanism``).
    what : str
        What it limits, in words (``"moment arm"``), for sentences and labels.
    bound : str
        The mechanism's field [SI] that holds the limit's value; ``"field[i]"`` for element i of
        a tuple field.
    sense : int
        +1 for a lower limit (value = limit + margin), −1 for an upper one (value = limit −
        margin).
    unit : str
        A key of :data:`LIMIT_UNITS`: the unit of the margin and of the limit.
    profile : int or None
        The profile (1-based) a limit of one of several profiles belongs to.
    """

    name: str
    what: str
    bound: str
    sense: int = +1
    unit: str = "m"
    profile: int | None = None

    def value(self, mech) -> float:
        """The limit's value [SI] on mechanism ``mech`` (inf where it has none)."""
        field, _, index = self.bound.partition("[")
        v = getattr(mech, field, 0.0)
        return float(v[int(index.rstrip("]"))] if index else v)

    @property
    def nlp_scale(self) -> float:
        """The size [SI] the NLP divides the margin by, so that its rows are O(1)."""
        return LIMIT_UNITS[self.unit][2]


@dataclass(frozen=True)
class Quantity:
    """A named entry of a mechanism's parameter vector q, unknown vector z or residual R,
    declared once with its unit and meaning (labels, manifests and docs read it).

    ``unit`` is SI ("m", "rad", "m/rad", "N", "-"); a residual row in "m" is scaled to
    millimetres in the NLP, one in "rad" or "-" is left as it is. ``placed`` marks a parameter
    the workshop sets by placing a part (a spring end, an idler), for the tolerance band
    (:mod:`cadcam.verify.tolerance`): ``"length"`` moves by the placement tolerance, and
    ``"angle:NAME"`` turns by it over the arm of parameter ``NAME``.
    """

    name: str
    unit: str
    description: str
    placed: str = ""


class Named:
    """The entries of a symbolic vector by the names of their declarations:
    ``Named(cls.parameters, q).idler_radius`` is ``q[0]`` for a wire cam."""

    def __init__(self, quantities: tuple[Quantity, ...], vector):
        self._index = {v.name: i for i, v in enumerate(quantities)}
        self._vector = vector

    def __getattr__(self, name: str):
        try:
            return self._vector[self._index[name]]
        except KeyError:
            raise AttributeError(f"no entry named {name!r}; declared: {', '.join(self._index)}") from None


@dataclass(frozen=True)
class Picture:
    """The words the figures and drawing sheets use for a mechanism's parts; a cable's by
    default. ``wound`` = "" draws no thick arc for the part of a profile up to the contact."""

    title: str = "profiles and cable"
    wound: str = "cable wrapped on it"
    free: str = "cable off the profile"
    contact: str = "departure point"
    anchor: str = "anchor"
    circle: str = "idler (+ centre)"
    arc: str = "designed (wrapped) arc"
    runs_on: str = "the cable runs on the red arc only"


#: Highest polynomial degree per basis: monomials are ill-conditioned beyond 15; Chebyshev
#: polynomials stay well-conditioned, and a multi-turn spiral needs the degree.
MAX_ORDER = {"monomial": 15, "chebyshev": 40}

#: The optional key every ``[[mechanisms]]`` table may have for its drawings.
LINK_ANGLE = Key("link_angle", "rad", "the world angle of the joint's link, from the joint axis towards its "
                 "mass, at θ = 0; the link turns with the mechanism's turning body (drawings only)", default=None,
                 default_text="for a pendulum target, where gravity along −y gives the target's torque "
                 "m g l sin(θ + phase)")

#: The keys every ``[[mechanisms]]`` table has, before the mechanism's own
#: (:attr:`Mechanism.spec_keys`): its kind, name and joint, its profiles' basis and limits.
MECHANISM_KEYS = KeyTable("[[mechanisms]]", "A mechanism on one joint with its designed profiles (one basis and "
                          "one set of limits for all its profiles); then the keys of its kind.", (
    Key("kind", "", "the mechanism's kind", "string", min_length=1),
    Key("name", "", "the mechanism's name", "string", default=None, default_text="'mechanism N'"),
    Key("joint", "", "the joint it turns with (1-based)", "integer", low=1),
    Key("basis", "", "the profiles' polynomial basis", "choice", choices=BASES, default="chebyshev"),
    Key("order", "", f"the profiles' polynomial degree, at most the basis's cap {MAX_ORDER}", "integer", low=1,
        high=max(MAX_ORDER.values()), default=3),
    Key("rho_min", "m", "the profiles' least radius", low=0, open_low=True, plausible=PART_SIZE),
    Key("rho_max", "m", "the profiles' greatest radius, above rho_min", low=0, open_low=True, plausible=PART_SIZE),
    Key("min_curvature_radius", "m", "the profiles' least radius of curvature (0: convex only)", low=0, default=0.0,
        plausible=PART_SIZE),
    LINK_ANGLE,
    Key("output_target", "", "the law x_d(θ) [m] the mechanism's output tracks, for a mechanism with an output "
        "(its keys: a target kind's, see Target kinds)", "table", default=None, default_text="none"),
))


@dataclass(frozen=True)
class Profile:
    """One designed profile ρ(φ) of a mechanism, with its radius and curvature limits [m]."""

    name: str
    basis: Basis
    rho_min: float
    rho_max: float
    #: Smallest radius of curvature allowed over the wrapped range [m] (0: convex only).
    min_curvature_radius: float = 0.0


@dataclass(frozen=True)
class Hook:
    """One member a mechanism provides, declared once: its group, whether every mechanism must
    write it, and what it is for; the checklist of docs/mechanisms.md follows these (a test
    holds the two in step) and :func:`register` refuses a class that lacks a required one."""

    name: str
    group: str
    required: bool = False


def _hooks(group: str, required: tuple[str, ...], optional: tuple[str, ...] = ()) -> tuple[Hook, ...]:
    return tuple(Hook(n, group, True) for n in required) + tuple(Hook(n, group, False) for n in optional)


#: The hooks of the interface, by group, in the order docs/mechanisms.md lists them.
HOOKS = (
    *_hooks("declarations", ("kind", "citation", "ports", "per_angle", "residual_rows"),
            ("parameters", "unknown_bounds", "n_profiles", "closure_rows", "output", "shorthand", "spec_keys")),
    *_hooks("geometry", ("residual", "guess", "displacements"),
            ("closure", "profile_rotation", "profile_domain", "wrap_end", "max_span", "windings")),
    *_hooks("limits", (), ("limits", "margins", "mounted_ports", "spring_room", "largest_arm", "mount_room",
                                 "fixed_sign_ports",
                                 "advice")),
    *_hooks("placement", (), ("placement_region", "placed")),
    *_hooks("starts and methods", (), ("start_radius", "prepare_start", "methods", "force_models", "force_arms",
                                       "legacy_force_models", "reference_angle")),
    *_hooks("spec", (), ("from_spec", "spec_fields")),
    *_hooks("drawing", (), ("picture", "link_rotation", "segments", "wraps", "circles", "spring_line",
                            "summary_lines")),
    *_hooks("files", (), ("port_length_from_file", "output_from_file", "free_spans_from_file")),
)

#: Members every mechanism has from the base class or derives from its hooks: not hooks.
PROVIDED = ("name", "joint", "profiles", "link_angle", "output_target", "parameter_names", "unknowns",
            "unknown_units", "residual_units", "margin_names", "spec_units", "named_parameters", "named_unknowns",
            "parameter_values", "placement_steps", "world_points", "arm", "planar", "offers", "bases",
            "structure", "citations", "check_torque_model", "has_file_model")


def missing_hooks(cls) -> list[str]:
    """The required :data:`HOOKS` that ``cls`` neither writes nor inherits from a mechanism
    other than the base, as ``group: name``."""
    def written(name: str) -> bool:
        return any(name in vars(k) for k in cls.__mro__ if k is not Mechanism and issubclass(k, Mechanism))
    return [f"{h.group}: {h.name}" for h in HOOKS if h.required and not written(h.name)]


@dataclass(frozen=True)
class Mechanism(ABC):
    """Base of every mechanism: a name, the joint it turns with (0-based) and its profiles; an
    abstract class whose required hooks (:data:`HOOKS`) :func:`register` checks at import.

    Subclasses are frozen dataclasses that add their numbers as fields and define the class
    attributes and class methods below; see docs/mechanisms.md.
    """

    name: str
    joint: int
    profiles: tuple[Profile, ...]
    #: :data:`LINK_ANGLE` [rad], or None (its default).
    link_angle: float | None = None

    kind: ClassVar[str] = ""
    citation: ClassVar[str] = ""
    ports: ClassVar[tuple[str, ...]] = ()
    #: The numbers q the symbolic model reads (:meth:`parameter_values` gives them, SI).
    parameters: ClassVar[tuple[Quantity, ...]] = ()
    #: The unknowns z solved at every angle (the first ones are the departure angles α_k).
    per_angle: ClassVar[tuple[Quantity, ...]] = ()
    #: The rows of R(θ, z) = 0 (:meth:`residual` stacked over :meth:`closure`).
    residual_rows: ClassVar[tuple[Quantity, ...]] = ()
    #: Names and units derived from the declarations above.
    parameter_names: ClassVar[tuple[str, ...]] = ()
    unknowns: ClassVar[tuple[str, ...]] = ()
    unknown_units: ClassVar[tuple[str, ...]] = ()
    residual_units: ClassVar[tuple[str, ...]] = ()
    #: Bounds (lo, hi) of each unknown in the NLP; empty: unbounded.
    unknown_bounds: ClassVar[tuple[tuple[float, float], ...]] = ()
    #: The per-pose limits :meth:`margins` returns, in its order (each margin ≥ 0 when met).
    limits: ClassVar[tuple[Limit, ...]] = ()
    #: Their names (derived from :attr:`limits`).
    margin_names: ClassVar[tuple[str, ...]] = ()
    force_models: ClassVar[tuple[str, ...]] = ()
    #: Old names of its force models (cadcam ≤ 0.1's ``friction_model``) → their names.
    legacy_force_models: ClassVar[dict[str, str]] = {}
    #: Joint angle [rad] at which the port displacements are zero.
    reference_angle: ClassVar[float] = 0.0
    #: Number of profiles the mechanism owns.
    n_profiles: ClassVar[int] = 1
    #: Number of :meth:`closure` rows (residual rows that need the wound lengths).
    closure_rows: ClassVar[int] = 0
    #: The unknown that is the mechanism's output displacement [m] ("" if none), and the law
    #: it should follow (a :class:`cadcam.targets.Target` of the joint angle, or None).
    output: ClassVar[str] = ""
    output_target: ClassVar[object] = None
    #: The words its pictures use (:class:`Picture`).
    picture: ClassVar[Picture] = Picture()
    #: A spec's top-level list of this mechanism, one per joint (a shorthand), or "".
    shorthand: ClassVar[str] = ""
    #: Its own spec keys, after :data:`MECHANISM_KEYS` (:meth:`from_spec` reads them; the
    #: reference and the result's schema list them).
    spec_keys: ClassVar[KeyTable] = KeyTable("", "", ())
    #: SI unit of each of its own spec keys (those of a sub-table by their own name), for
    #: labels (derived from :attr:`spec_keys`).
    spec_units: ClassVar[dict[str, str]] = {}
    #: Design methods of its own (:class:`DesignMethod`), besides the NLP.
    methods: ClassVar[tuple[DesignMethod, ...]] = ()
    #: The ports whose moment arm keeps one sign for every profile it may have (a cable that
    #: leaves a profile drawn around the joint axis), each with the spec keys that reverse that
    #: sign; what :func:`cadcam.verify.reachable.unreachable` reads to tell a spring that pulls
    #: the wrong way before any solve.
    fixed_sign_ports: ClassVar[dict[str, tuple[str, ...]]] = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        cls.margin_names = tuple(limit.name for limit in cls.limits)
        cls.parameter_names = tuple(v.name for v in cls.parameters)
        cls.unknowns = tuple(v.name for v in cls.per_angle)
        cls.unknown_units = tuple(v.unit for v in cls.per_angle)
        cls.residual_units = tuple(v.unit for v in cls.residual_rows)
        cls.spec_units = {k.name: k.unit for key in cls.spec_keys.keys
                          for k in (key.fields.keys if key.fields is not None else (key,)) if k.unit}

    @classmethod
    def named_parameters(cls, q) -> Named:
        """q's entries by name (:attr:`parameters`)."""
        return Named(cls.parameters, q)

    @classmethod
    def named_unknowns(cls, z) -> Named:
        """z's entries by name (:attr:`per_angle`)."""
        return Named(cls.per_angle, z)

    # -- what a subclass provides ---------------------------------------------------------------
    def parameter_values(self) -> tuple[float, ...]:
        """The numbers q of :attr:`parameter_names` (SI)."""
        return tuple(float(getattr(self, n)) for n in self.parameter_names)

    def placement_region(self) -> dict[str, tuple[float, float]]:
        """The parameters (of :attr:`parameter_names`) the NLP places, each with its (least,
        largest) value [SI]: a mount the spec lets the design move within a region. Its start
        is the parameter's value. Default: none, every parameter is fixed."""
        return {}

    def placed(self, values: dict[str, float]) -> "Mechanism":
        """This mechanism with the parameters of :meth:`placement_region` set to ``values``
        [SI] (the NLP's answer). Default: itself (it places nothing)."""
        return self

    def placement_steps(self, placement: float) -> np.ndarray:
        """The step of each of :attr:`parameters` [SI] that a part placed ``placement`` [m] off
        makes (:attr:`Quantity.placed`): ``placement`` for a placed length, ``placement`` over
        its arm for a placed angle, 0 for a number the workshop does not place."""
        values = dict(zip(self.parameter_names, self.parameter_values()))
        return np.array([placement / (values[quantity.placed.split(":")[1]] if ":" in quantity.placed else 1.0)
                         if quantity.placed else 0.0 for quantity in self.parameters])

    @classmethod
    @abstractmethod
    def residual(cls, bases, theta, z, c, q):
        """(R, branch_error): R(z) = 0 fixes z; branch_error ≥ 0 is zero on the physical branch."""
        raise NotImplementedError

    @classmethod
    def closure(cls, bases, theta, z, wound, c, q):
        """Rows of R = 0 that need the wound lengths ``wound`` [m] (W_k = ∫₀^α_k √(ρ² + ρ′²) dφ
        on each profile, from its anchor): a constant cable length (the differential pair).
        Stacked under :meth:`residual`; :attr:`residual_units` covers both. Default: none."""
        return ca.SX(0, 1)

    @classmethod
    @abstractmethod
    def guess(cls, bases, theta, c, q):
        """A closed-form start for z (a column of len(unknowns))."""
        raise NotImplementedError

    @classmethod
    @abstractmethod
    def displacements(cls, bases, theta, z, z_ref, wrapped, c, q):
        """Port displacements d [m] from the reference pose (a column of len(ports))."""
        raise NotImplementedError

    @classmethod
    def force_arms(cls, bases, model, theta, z, c, q, order, integrals):
        """The arms of a named force model (a column of len(ports)); only for
        :attr:`force_models`. ``integrals`` says how a model evaluates the integrals it has:
        ``"closed-form"`` (the NLP's, the export's) or ``"quadrature"`` of ``order`` points per
        segment (the re-check's)."""
        raise NotImplementedError

    @classmethod
    def margins(cls, bases, theta, z, c, q, arm):
        """Per-pose limits of the mechanism (a column, one row per :attr:`limits`, each in its
        limit's unit), each ≥ 0 when met, given the port arms ``arm`` [m]; imposed by the NLP
        at every grid angle and checked by the re-check."""
        return ca.SX(0, 1)

    #: The ports whose spring hangs from a mount fixed to its body, along the cable's last free
    #: span (:meth:`spring_room`); empty: the mechanism bounds no spring's length.
    mounted_ports: ClassVar[tuple[str, ...]] = ()

    def largest_arm(self, port: str) -> float | None:
        """The largest moment arm [m] a spring on ``port`` can have on the joint, whatever the
        profiles, for screening springs by force, stroke and room before any design
        (:func:`cadcam.sweep.springs.slot_need`); None where the mechanism bounds none.
        Default: none is bounded."""
        return None

    def mount_room(self, port: str, arms: np.ndarray) -> np.ndarray | None:
        """For each moment arm h [m] of ``arms`` (each within :meth:`largest_arm`), the longest
        straight line [m] from the mount of a spring on ``port`` (one of :attr:`mounted_ports`)
        to where a cable of that arm can leave the profiles, over every placement the spec
        allows: at most the spring's free length plus its extension at that arm (:meth:`spring_room`),
        for screening springs by length before any design. It must not decrease as h falls
        (the screen bounds it between the arms it is given). None where the port mounts no
        spring. Default: no port does."""
        return None

    @classmethod
    def spring_room(cls, bases, theta, z, c, q, port: str):
        """The straight length [m] a spring on ``port`` (one of :attr:`mounted_ports`) has at
        a pose: from its mount along the cable's last free span to where the cable leaves the
        profile. The spring, free length L0 plus extension x, must fit in it (its hook never
        reaches the profile), and the cable from its anchor on the profile to the hook is the
        path to the mount less L0 + x. Default: no room is bounded (no mounted ports)."""
        raise NotImplementedError(f"{cls.kind} mounts no spring on port {port!r}")

    @classmethod
    def wrap_end(cls, first, last, q):
        """Each profile's departure angle at the most-wound end of the joint range, from the
        values at the ``first`` and ``last`` grid angles: convexity and ρ limits hold over
        [0, wrap_end]. Default: the cable winds on as θ grows."""
        return last

    @staticmethod
    def profile_rotation(theta):
        """World angle of the profile's polar axis at joint angle θ [rad]: −θ for a profile that
        turns with the joint (a point at polar angle φ sits at world angle φ − θ,
        Johnston2023 Sec. 2); a mechanism whose profile is fixed to ground returns 0."""
        return -theta

    @classmethod
    def profile_domain(cls, theta_range) -> tuple[float, float]:
        """Design interval [rad] of a profile's basis for a joint range ``theta_range``: every
        departure angle α ≤ θ_max + π/2 (Johnston2023's cam; a mechanism may override)."""
        return (0.0, theta_range[1] + np.pi / 2)

    def world_points(self, theta, phi, rho, k: int = 0):
        """World coordinates [m] of points of profile ``k`` at polar angles ``phi`` [rad] and
        radii ``rho`` [m] at joint angle ``theta`` [rad] (for pictures and outlines)."""
        ang = np.asarray(phi) + self.profile_rotation(theta)
        return rho * np.cos(ang), rho * np.sin(ang)

    def link_rotation(self, theta):
        """World angle [rad] by which the joint's link has turned at joint angle θ: the link is
        fixed to the body that turns with the joint, by default the profile
        (:meth:`profile_rotation`)."""
        return self.profile_rotation(theta)

    def arm(self, theta: float, target) -> tuple[np.ndarray, str] | None:
        """For drawings: where the joint's link puts the mass of a pendulum ``target`` at joint
        angle θ (a world point [m]), and the words for it; None for other targets.

        The link points along :attr:`link_angle` at θ = 0 and turns by :meth:`link_rotation`.
        Without ``link_angle`` it points where gravity along −y gives the target's torque: the
        mass at height l sin ψ asks the springs for dV/dθ = −m g l cos ψ · dψ/dθ, which is
        m g l sin(θ + phase) for ψ = π/2 + r(θ + phase), r = ±1 the link's turn per radian."""
        if target.kind != "pendulum":
            return None
        d = target.data
        if self.link_angle is None:
            angle = np.pi / 2 + self.link_rotation(theta + d["phase"])
        else:
            angle = self.link_angle + self.link_rotation(theta)
        return (d["length"] * np.array([np.cos(angle), np.sin(angle)]),
                f"arm: {d['mass']:g} kg at {1e3 * d['length']:g} mm")

    def spring_line(self, theta: float, z: np.ndarray, c: np.ndarray, port: str,
                    sign: float) -> tuple[np.ndarray, np.ndarray, float] | None:
        """For drawings: the line a spring on ``port`` (with ``sign``, ±1, in its ports) lies
        on at the pose θ: the end it is drawn from (a world point [m]), the unit vector it runs
        along from there, and the room it has along it [m] (inf: no bound). None where the
        mechanism does not place the springs of that port (the default)."""
        return None

    def segments(self, theta: float, z: np.ndarray, c: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Straight cable spans (start, end) [m] to draw at the pose θ."""
        return []

    def wraps(self, theta: float, z: np.ndarray, c: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Curves (x, y) [m] of cable lying on idlers at the pose θ, to draw."""
        return []

    def start_radius(self, profile: Profile) -> float:
        """Radius of a feasible circular starting profile [m]."""
        return 1.2 * profile.rho_min

    def circles(self, theta: float, z: np.ndarray, c: np.ndarray) -> list[tuple[np.ndarray, float]]:
        """Circles (centre [m], radius [m]) to draw at the pose θ [rad] with unknowns ``z`` and
        stacked coefficients ``c``: idlers, guide pulleys, points."""
        return []

    @classmethod
    def from_spec(cls, reader, name: str, joint: int, profiles, theta_range=(0.0, 0.0)) -> "Mechanism":
        """Read the mechanism's own keys, :attr:`spec_keys`, from its spec table
        (``reader.read(key, default)``, ``reader.table_reader(key)``); ``theta_range`` [rad] is
        its joint's range."""
        return cls(name=name, joint=joint, profiles=profiles)

    def spec_fields(self) -> dict:
        """The mechanism's own keys in the spec form (inverse of :meth:`from_spec`)."""
        return {}

    def max_span(self) -> float:
        """The widest joint range [rad] this mechanism may turn over: its cable (or contact)
        runs on a planar profile, which holds at most one turn; a mechanism whose profiles
        climb a helical groove allows more."""
        return 2 * np.pi

    @property
    def windings(self) -> tuple[float, ...]:
        """Each profile's winding on the part seen from the front: +1 counter-clockwise, −1
        clockwise. Outlines are drawn in the profile's own frame, where the cable winds
        counter-clockwise, so a −1 profile's drawing is the part seen from its back. Default:
        every profile as drawn."""
        return (1.0,) * self.n_profiles

    def planar(self) -> bool:
        """Whether its profiles are cut as planar outlines (a turn at most), which the NLP
        closes around the hub: not a helical groove."""
        return self.max_span() <= 2 * np.pi

    def offers(self, method: str) -> bool:
        """Whether this mechanism can be designed by its own ``method``."""
        return any(m.name == method for m in self.methods)

    @classmethod
    def prepare_start(cls, problem, design):
        """The problem and start design with this kind's mechanisms given their own start (a
        closed form, an envelope), from ``design``'s circles; default: unchanged."""
        return problem, design

    @classmethod
    def advice(cls, problem) -> list[str]:
        """One-line notes, each with its fix, on what this kind's mechanisms in ``problem``
        cannot do exactly, told before the solve (a bound the papers prove; not a refusal: the
        design may still meet its acceptance); default: none."""
        return []

    @classmethod
    def summary_lines(cls, evaluation) -> list[str]:
        """Lines this kind adds to a result's summary, from the fine re-check ``evaluation``."""
        return []

    # -- files: the part as written, read back ------------------------------------------------
    # ``outlines`` are the mechanism's profiles read back from the workshop files, each a
    # :class:`cadcam.physics.outline.FileOutline` on the cable's centre line in the profile's own
    # frame; the file model computes from them by plane geometry alone what the part does
    # (:mod:`cadcam.verify.file_model`, :mod:`cadcam.outputs.verification`).
    def port_length_from_file(self, outlines: list, port: str, theta) -> np.ndarray:
        """Length [m] of port ``port`` at joint angles ``theta`` (n,) [rad] recomputed from
        ``outlines``, the joint torque's file model (its change from the reference angle and
        its derivative are taken by the caller). Default: no file model, and
        ``verification.md`` says so."""
        raise NotImplementedError(f"no file model of {self.kind}")

    def output_from_file(self, outlines: list, theta) -> np.ndarray:
        """The :attr:`output` displacement [m] at joint angles ``theta`` (n,) [rad] recomputed
        from ``outlines`` (NaN where it has none), for a mechanism with an :attr:`output`.
        Default: no file model."""
        raise NotImplementedError(f"no file model of {self.kind}'s output")

    def free_spans_from_file(self, outlines: list, theta) -> list | None:
        """Each profile's free span at joint angles ``theta`` (n,) [rad] recomputed from
        ``outlines``: (where the cable leaves the outline, where it ends), both (n, 2) [m] in
        the outline's frame, per profile; their clearance from the cut part is checked.
        Default: None, no cable leaves the part on a free span (a follower rides it)."""
        return None

    @classmethod
    def has_file_model(cls) -> bool:
        """Whether the mechanism recomputes its ports from its written files: it overrides
        :meth:`port_length_from_file`."""
        return cls.port_length_from_file is not Mechanism.port_length_from_file

    # -- generic -------------------------------------------------------------------------------
    @property
    def bases(self) -> tuple[Basis, ...]:
        return tuple(p.basis for p in self.profiles)

    def structure(self):
        """What the symbolic functions of this mechanism depend on (its class and bases)."""
        return type(self), self.bases

    def citations(self) -> tuple[str, ...]:
        """Tags of the papers this mechanism rests on (cadcam.citations.PAPERS)."""
        return (self.citation,) if self.citation else ()

    def check_torque_model(self, model: str) -> str:
        """``model`` if this mechanism can compute it, else ValueError naming what it can."""
        ok = (ENERGY,) + self.force_models
        if model not in ok:
            raise ValueError(f"torque model {model!r} is not available for mechanism "
                             f"{self.name!r} ({self.kind}); expected one of {ok}")
        return model


def _symbols(cls, bases):
    theta = ca.SX.sym("theta")
    z = ca.SX.sym("z", len(cls.unknowns))
    c = ca.SX.sym("c", sum(b.size for b in bases))
    q = ca.SX.sym("q", len(cls.parameter_names))
    return theta, z, c, q


def split_coefficients(bases, c) -> list:
    """The stacked coefficient vector ``c`` cut into one piece per profile."""
    out, k = [], 0
    for b in bases:
        out.append(c[k:k + b.size])
        k += b.size
    return out


@lru_cache(maxsize=64)
def pose_residual_function(structure) -> ca.Function:
    """``pose_residual(theta, z, wound, c, q) -> (R, branch_error)``: :meth:`Mechanism.residual`
    stacked over :meth:`Mechanism.closure`, given the wound lengths (the NLP lifts them)."""
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    wound = ca.SX.sym("wound", len(bases))
    R, branch = cls.residual(bases, theta, z, c, q)
    R = ca.vertcat(R, cls.closure(bases, theta, z, wound, c, q))
    return ca.Function("pose_residual", [theta, z, wound, c, q], [R, branch],
                       ["theta", "z", "wound", "c", "q"], ["R", "branch_error"])


def wound_lengths(bases, z, c):
    """Each profile's wound length W_k(α_k) [m] (α_k = z[k]) by
    :func:`cadcam.physics.wrap.wound_length`."""
    return ca.vertcat(*[wound_length(b, z[k], ck) for k, (b, ck) in enumerate(zip(bases, split_coefficients(bases, c)))])


@lru_cache(maxsize=64)
def residual_function(structure) -> ca.Function:
    """``residual(theta, z, c, q) -> (R, branch_error)`` of a mechanism structure: the whole
    system R(z) = 0, closure rows with their wound lengths by quadrature."""
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    wound = wound_lengths(bases, z, c) if cls.closure_rows else ca.DM.zeros(len(bases))
    R, branch = pose_residual_function(structure)(theta, z, wound, c, q)
    return ca.Function("residual", [theta, z, c, q], [R, branch],
                       ["theta", "z", "c", "q"], ["R", "branch_error"])


@lru_cache(maxsize=64)
def guess_function(structure) -> ca.Function:
    """``guess(theta, c, q) -> z``: the mechanism's closed-form start."""
    cls, bases = structure
    theta, _, c, q = _symbols(cls, bases)
    return ca.Function("guess", [theta, c, q], [cls.guess(bases, theta, c, q)],
                       ["theta", "c", "q"], ["z"])


#: Largest turn [rad] of any departure angle in one Newton step (:func:`newton_from_function`).
NEWTON_MAX_TURN = 0.1


@lru_cache(maxsize=64)
def newton_from_function(structure, steps: int = 8) -> ca.Function:
    """``newton_from(theta, z0, c, q) -> z`` by ``steps`` unrolled Newton iterations from z0,
    each step shortened so that no angle among the unknowns turns by more than
    :data:`NEWTON_MAX_TURN`.

    Near the root the full step is short and Newton converges quadratically; where the residual
    is nearly flat (a profile nearly straight where the cable leaves it, near a fold of the
    departure at the end of Endo2010's ordinary pendulum's range) the full step would land far
    outside the wrap, where other roots lie. A closed-form expression (no callback, no loop)
    that code-generates and differentiates like any other.
    """
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    R = residual_function(structure)(theta, z, c, q)[0]
    delta = ca.solve(ca.jacobian(R, z), R)
    turn = ca.mmax(ca.fabs(ca.vertcat(*[delta[k] for k, unit in enumerate(cls.unknown_units) if unit == "rad"])))
    z_next = z - delta * ca.fmin(1, NEWTON_MAX_TURN / turn)
    step = ca.Function("step", [z, theta, c, q], [z_next])
    z0 = ca.SX.sym("z0", z.shape[0])
    zk = z0
    for _ in range(steps):
        zk = step(zk, theta, c, q)
    return ca.Function("newton_from", [theta, z0, c, q], [zk], ["theta", "z0", "c", "q"], ["z"])


def _density(bases, z, c):
    """dW/dz (profiles × unknowns): the wound length W_k grows by √(ρ² + ρ′²) per radian of
    its departure angle α_k = z[k] (Johnston2023 Eq. 10) and depends on no other unknown."""
    density = ca.SX.zeros(len(bases), z.shape[0])
    for k, (b, ck) in enumerate(zip(bases, split_coefficients(bases, c))):
        rho, drho, _, _ = profile_function(b)(z[k], ck)
        density[k, k] = arc_length_density(rho, drho)  # Johnston2023 Eq. 10
    return density


def _along_solutions(R, z, wound, density, rhs):
    """dz that keeps R(z, W(z)) = 0 when the rest of R moves by ``rhs`` (a column per
    direction): −(R_z + R_W dW/dz)⁻¹ rhs, the implicit function theorem."""
    return -ca.solve(ca.jacobian(R, z) + ca.mtimes(ca.jacobian(R, wound), density), rhs)


def energy_arms(structure, theta, z, wound, wrapped, c, q, d):
    """dd/dθ [m/rad] of port displacements ``d`` (expressions of θ, z, the wrapped lengths and
    c) along the solution manifold R(θ, z, W(z)) = 0, by the implicit function theorem
    (dW_k/dα_k = √(ρ² + ρ′²), Johnston2023 Eq. 10)."""
    cls, bases = structure
    R = pose_residual_function(structure)(theta, z, wound, c, q)[0]
    density = _density(bases, z, c)
    dz = _along_solutions(R, z, wound, density, ca.jacobian(R, theta))
    dl = ca.mtimes(density, dz)
    return (ca.jacobian(d, theta) + ca.mtimes(ca.jacobian(d, z), dz)
            + ca.mtimes(ca.jacobian(d, wrapped), dl))


@lru_cache(maxsize=64)
def pose_change_function(structure) -> ca.Function:
    """How a pose moves when the part is made differently, the joint angle held: the change
    of the residuals R(θ, z, W) to first order, and the change of the unknowns that keeps it
    zero (the implicit function theorem, as :func:`energy_arms` for a turn of the joint).

    ``pose_change(theta, z, wound, c, q, dz, dW, dc, dq) -> (dR, dz_solution)`` for a change
    ``dz`` of the unknowns, ``dW`` [m] of the wound lengths at fixed angles (their own change;
    :func:`wound_change_function`), ``dc`` of the coefficients [m] and ``dq`` of the numbers
    (SI): dR = (R_z + R_W dW/dz) dz + R_W dW + R_c dc + R_q dq, and the dz at which it is zero.
    """
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    wound, dW = ca.SX.sym("wound", len(bases)), ca.SX.sym("dW", len(bases))
    dz, dc, dq = ca.SX.sym("dz", z.shape[0]), ca.SX.sym("dc", c.shape[0]), ca.SX.sym("dq", q.shape[0])
    R = pose_residual_function(structure)(theta, z, wound, c, q)[0]
    density = _density(bases, z, c)
    rhs = ca.mtimes(ca.jacobian(R, wound), dW) + ca.mtimes(ca.jacobian(R, c), dc) + ca.mtimes(ca.jacobian(R, q), dq)
    dR = ca.mtimes(ca.jacobian(R, z) + ca.mtimes(ca.jacobian(R, wound), density), dz) + rhs
    return ca.Function("pose_change", [theta, z, wound, c, q, dz, dW, dc, dq],
                       [dR, _along_solutions(R, z, wound, density, rhs)],
                       ["theta", "z", "wound", "c", "q", "dz", "dW", "dc", "dq"], ["dR", "dz_solution"])


@lru_cache(maxsize=64)
def wound_change_function(structure) -> ca.Function:
    """``wound_change(z, c, dc) -> dW``: the change [m] of each profile's wound length
    (:func:`wound_lengths`) at the angles ``z`` when its coefficients change by ``dc`` [m]."""
    cls, bases = structure
    _, z, c, _ = _symbols(cls, bases)
    dc = ca.SX.sym("dc", c.shape[0])
    return ca.Function("wound_change", [z, c, dc], [ca.jtimes(wound_lengths(bases, z, c), c, dc)],
                       ["z", "c", "dc"], ["dW"])


@lru_cache(maxsize=64)
def port_change_function(structure, model: str, order: int, integrals: str = "closed-form") -> ca.Function:
    """The first-order change of :func:`port_function`'s displacements and moment arms at a
    pose when the part is made differently, the joint angle held, given how the pose there and
    at the reference angle move (``dz``, ``dz_ref``; :func:`pose_change_function`) and the
    wound lengths' own change at both (``dW``, ``dW_ref``): the wrapped and wound lengths
    move with their ends and their profile.

    ``port_change(theta, z, z_ref, wrapped, wound, c, q, dz, dz_ref, dW, dW_ref, dc, dq) ->
    (dd, darm)``.
    """
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    z_ref, dz, dz_ref = (ca.SX.sym(name, z.shape[0]) for name in ("z_ref", "dz", "dz_ref"))
    wrapped, wound, dW, dW_ref = (ca.SX.sym(name, len(bases)) for name in ("wrapped", "wound", "dW", "dW_ref"))
    dc, dq = ca.SX.sym("dc", c.shape[0]), ca.SX.sym("dq", q.shape[0])
    # W(α) = W(α_ref) + wrapped (Johnston2023 Eq. 10, 14): each end moves with its angle
    dwound = ca.mtimes(_density(bases, z, c), dz) + dW
    dwrapped = dwound - ca.mtimes(_density(bases, z_ref, c), dz_ref) - dW_ref
    d, arm, _, _ = port_function(structure, model, order, integrals)(theta, z, z_ref, wrapped, wound, c, q)
    inputs, steps = ca.vertcat(z, z_ref, wrapped, wound, c, q), ca.vertcat(dz, dz_ref, dwrapped, dwound, dc, dq)
    names = ["theta", "z", "z_ref", "wrapped", "wound", "c", "q", "dz", "dz_ref", "dW", "dW_ref", "dc", "dq"]
    return ca.Function("port_change", [theta, z, z_ref, wrapped, wound, c, q, dz, dz_ref, dW, dW_ref, dc, dq],
                       [ca.jtimes(d, inputs, steps), ca.jtimes(arm, inputs, steps)], names, ["dd", "darm"])


@lru_cache(maxsize=64)
def port_function(structure, model: str, order: int, integrals: str = "closed-form") -> ca.Function:
    """Per-angle port quantities of a mechanism under torque ``model``.

    ``ports(theta, z, z_ref, wrapped, wound, c, q) -> (d, arm, R, branch_error)``: port
    displacements [m] from the reference pose, their moment arms [m] (``energy``: dd/dθ by
    :func:`energy_arms`; otherwise the mechanism's named force model, with ``order`` and
    ``integrals`` passed on), and the residuals at (θ, z). ``wrapped`` holds each profile's
    wrapped length between α_k(θ_ref) and α_k(θ) [m] (Johnston2023 Eq. 10) and ``wound`` the
    length from its anchor to α_k(θ) [m] (used by closure rows only), inputs so that callers
    integrate them per angle (the re-check) or cumulatively along a grid (the NLP).
    """
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    z_ref = ca.SX.sym("z_ref", z.shape[0])
    wrapped = ca.SX.sym("wrapped", len(bases))
    wound = ca.SX.sym("wound", len(bases))
    d = cls.displacements(bases, theta, z, z_ref, wrapped, c, q)
    if model == ENERGY:
        arm = energy_arms(structure, theta, z, wound, wrapped, c, q, d)
    else:
        arm = cls.force_arms(bases, model, theta, z, c, q, order, integrals)
    R, branch = pose_residual_function(structure)(theta, z, wound, c, q)
    return ca.Function("ports", [theta, z, z_ref, wrapped, wound, c, q], [d, arm, R, branch],
                       ["theta", "z", "z_ref", "wrapped", "wound", "c", "q"],
                       ["d", "arm", "R", "branch_error"])


@lru_cache(maxsize=64)
def pose_function(structure, model: str, order: int, integrals: str = "closed-form") -> ca.Function:
    """One pose of a mechanism whose unknowns are solved at θ and at its reference angle: the
    assembly the re-check maps over its grid and the exported model calls symbolically.

    ``pose(theta, z, z_ref, c, q) -> (d, arm, R, branch_error)`` as :func:`port_function`,
    with each profile's wrapped length from α_k(θ_ref) to α_k(θ) by an ``order``-point
    Gauss–Legendre rule (Johnston2023 Eq. 10) and its wound length W_k(α_k(θ_ref)) plus that.
    (The NLP lifts the wrapped lengths to variables instead and calls :func:`port_function`.)
    """
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    z_ref = ca.SX.sym("z_ref", z.shape[0])
    wrapped = ca.vertcat(*[length_function(b, order)(z_ref[k], z[k], ck)  # Johnston2023 Eq. 10
                           for k, (b, ck) in enumerate(zip(bases, split_coefficients(bases, c)))])
    wound = wound_lengths(bases, z_ref, c) + wrapped
    d, arm, R, branch = port_function(structure, model, order, integrals)(theta, z, z_ref, wrapped, wound, c, q)
    return ca.Function("pose", [theta, z, z_ref, c, q], [d, arm, R, branch],
                       ["theta", "z", "z_ref", "c", "q"], ["d", "arm", "R", "branch_error"])


@lru_cache(maxsize=64)
def room_function(structure, port: str) -> ca.Function:
    """``room(theta, z, c, q) -> room``: the room [m] of a spring on the mounted ``port``
    (:meth:`Mechanism.spring_room`)."""
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    return ca.Function("room", [theta, z, c, q], [cls.spring_room(bases, theta, z, c, q, port)],
                       ["theta", "z", "c", "q"], ["room"])


@lru_cache(maxsize=64)
def margin_function(structure) -> ca.Function:
    """``margins(theta, z, c, q, arm) -> m``: the mechanism's per-pose limits [m]."""
    cls, bases = structure
    theta, z, c, q = _symbols(cls, bases)
    arm = ca.SX.sym("arm", len(cls.ports))
    return ca.Function("margins", [theta, z, c, q, arm], [cls.margins(bases, theta, z, c, q, arm)],
                       ["theta", "z", "c", "q", "arm"], ["m"])


#: Newton iterations of :meth:`DepartureSolver.solve`'s first pass, over every angle from its
#: start: from a start in its root's basin Newton converges in a few. An angle that has not
#: converged by then is solved from a converged neighbour's z (and, where none converges, from
#: its start with every iteration) instead of iterating on from a start that is not leading it
#: there: on a profile far from circular those iterations were most of a fine re-check's time.
FIRST_PASS_ITER = 12


class DepartureSolver:
    """Newton rootfinder for a mechanism's unknowns z of a fixed design at many angles."""

    def __init__(self, structure, abstol: float = 1e-14, max_iter: int = 50):
        cls, bases = structure
        theta, z, c, q = _symbols(cls, bases)
        self.residual = residual_function(structure)
        self._guess = guess_function(structure)
        g = ca.Function("g", [z, ca.vertcat(theta, c, q)], [self.residual(theta, z, c, q)[0]])
        options = {"abstol": abstol, "error_on_fail": False,
                   "show_eval_warnings": False}  # failures show in the residual
        self._rf = ca.rootfinder("departure", "newton", g, {**options, "max_iter": max_iter})
        self._first = ca.rootfinder("departure_first", "newton", g,
                                    {**options, "max_iter": min(FIRST_PASS_ITER, max_iter)})

    def symbolic(self, theta, c, q, start=None):
        """z at θ as an expression (MX) of θ, c and q: the rootfinder from ``start`` (default
        the guess), its derivatives by the implicit function theorem (the torque model's
        departure)."""
        return self._rf(self._guess(theta, c, q) if start is None else start, ca.vertcat(theta, c, q))

    def guess(self, theta, c, q) -> np.ndarray:
        """Initial z (rows: unknowns) at each θ in ``theta``."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        return np.asarray(mapped(self._guess, theta.size)(theta, c, q)).reshape(-1, theta.size)

    def solve(self, theta, c, q, start=None, tol: float = 1e-9):
        """z (rows: unknowns) and the max |residual| at each θ; ``start`` overrides the guess.

        Angles where Newton did not reach ``tol`` from its start in :data:`FIRST_PASS_ITER`
        iterations are solved again from a converged neighbour's z (continuation along the
        grid), sweep after sweep, and those still left from their start with every iteration.
        Then a run of angles whose z jumps away from the rest (another root of the same
        equations: the guess of a strongly non-circular profile can fall into its basin) is
        solved again by continuation from the longest run without a jump, one angle at a time;
        see :func:`_jumps`.
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        c, q = (np.asarray(v, dtype=float).ravel() for v in (c, q))
        z0 = self.guess(theta, c, q) if start is None else np.asarray(start, dtype=float)
        z, res = self._solve(theta, z0, c, q, self._first)
        order = np.argsort(theta, kind="stable")  # neighbours in angle
        while True:
            good = res[order] <= tol
            left = np.r_[False, good[:-1]] & ~good
            right = np.r_[good[1:], False] & ~good
            todo = left | right
            if not todo.any():
                break
            idx = order[todo]
            src = order[np.where(left, np.arange(good.size) - 1, np.arange(good.size) + 1)[todo]]
            zt, rt = self._solve(theta[idx], z[:, src], c, q)
            _keep_better(z, res, idx, zt, rt)
            if not np.any(rt <= tol):  # no progress: what is left does not converge
                break
        unsolved = np.flatnonzero(~(res <= tol))
        if unsolved.size:  # no neighbour led them there: every iteration from their start
            _keep_better(z, res, unsolved, *self._solve(theta[unsolved], z0[:, unsolved], c, q))
        return self._continued(theta, z, res, order, c, q, tol)

    def _continued(self, theta, z, res, order, c, q, tol):
        """``z`` with the runs cut off by jumps re-solved by continuation, outward from the
        longest run, where that converges (else the angle keeps its root)."""
        cuts = _jumps(z[:, order])
        if not cuts.size:
            return z, res
        edges = np.r_[0, cuts, order.size]
        k = int(np.argmax(np.diff(edges)))
        lo, hi = edges[k], edges[k + 1]  # the trusted run: sorted positions lo … hi − 1
        for steps in (range(hi, order.size), range(lo - 1, -1, -1)):
            for pos in steps:
                prev = pos - 1 if pos >= hi else pos + 1
                i, j = order[pos], order[prev]
                zt, rt = self._solve(theta[i:i + 1], z[:, j:j + 1], c, q)
                if rt[0] <= tol:
                    z[:, i], res[i] = zt[:, 0], rt[0]
        return z, res

    def _solve(self, theta, z0, c, q, rootfinder=None):
        """z and the max |residual| at each θ, Newton (``rootfinder``, by default with every
        iteration) from ``z0``."""
        n = theta.size
        p = np.vstack([theta, np.tile(c[:, None], (1, n)), np.tile(q[:, None], (1, n))])
        z = np.asarray(direct(mapped(rootfinder or self._rf, n))(z0, p)).reshape(-1, n)
        R = np.asarray(on_points(self.residual, n)(theta, z, c, q)[0]).reshape(-1, n)
        return z, np.abs(R).max(axis=0)


def _keep_better(z, res, idx, zt, rt) -> None:
    """Replace, in place, z and the residual at the angles ``idx`` by the new solve's ``zt``
    and ``rt`` where that residual is smaller (or finite where the old one is not)."""
    better = (rt < res[idx]) | (np.isfinite(rt) & ~np.isfinite(res[idx]))
    z[:, idx[better]], res[idx[better]] = zt[:, better], rt[better]


#: A step of z between neighbouring angles is a jump to another root if it exceeds this many
#: times the median step (and :data:`JUMP_FLOOR`).
JUMP_RATIO = 20.0
#: Smallest step [in the unknowns' units, rad for a wire cam] that counts as a jump.
JUMP_FLOOR = 0.05


def _jumps(z: np.ndarray) -> np.ndarray:
    """Positions k (in angle order) where z jumps between angle k − 1 and k: the largest change
    of any unknown is above both JUMP_RATIO × its median over the grid and JUMP_FLOOR."""
    if z.shape[1] < 3:
        return np.array([], dtype=int)
    step = np.abs(np.diff(z, axis=1)).max(axis=0)
    limit = max(JUMP_RATIO * float(np.median(step)), JUMP_FLOOR)
    return np.flatnonzero(step > limit) + 1


@lru_cache(maxsize=64)
def departure_solver(structure) -> DepartureSolver:
    """Cached :class:`DepartureSolver` of a mechanism structure."""
    return DepartureSolver(structure)
