"""What an element kind is: one descriptor per kind, from which every per-kind table derives.

A kind is this descriptor plus its numba force law and tangent (the branches of
`analysis.models.element_force` / `element_tangent` for its `Kind.code`). Everything else
that depends on the kind reads the descriptor:

* the model file's parameter names, optional defaults and positivity (`analysis.models._model`);
* the reverse-path basis function and the coefficient it estimates (`analysis.models._basis`);
* the harmonic-balance fit's start scales and bounds (`analysis.hbm._hbm_fit`);
* the plant's substep choice (`analysis.plant.auto_oversample`);
* the diagnosis library, its seeds and its physical constraints (`analysis.diagnose`);
* the report's units (`nlid_lab.reports._report`).

A lookup of a kind that is not here raises `InputError` (`lookup`); nothing falls back to a
default. New kinds are added here (plus their law branch) or, without editing the package,
registered at run time by `analysis.models.register_kind` with a jitted law.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, NamedTuple

import numpy as np

from ..errors import InputError


class Refs(NamedTuple):
    """Physical reference scales of a data set (start scales of a harmonic-balance fit).

    ``k`` largest diagonal stiffness, ``f`` largest force amplitude, ``u`` largest response
    amplitude at the drive, ``c`` largest diagonal damping, ``v`` velocity scale
    (``u`` times the median drive frequency in rad/s).
    """

    k: float
    f: float
    u: float
    c: float
    v: float


@dataclass(frozen=True)
class Param:
    """One element parameter.

    Attributes
    ----------
    name : str
        Key in the model file.
    meaning : str
        A few words for messages (e.g. ``"width"``).
    unit : str
        SI unit.
    scale : callable
        ``scale(refs: Refs) -> float``: typical magnitude in the data, the nominal start of
        a harmonic-balance fit.
    positive : bool
        Must be > 0 (fitted as a logarithm).
    default : float, optional
        Value when the model file omits it (makes the parameter optional).
    bounds : (float, float), optional
        Absolute fit bounds (default: `analysis.hbm._hbm_fit` decades around the start).
    smallest, largest : float, optional
        Smallest and largest value a model file may give (beyond ``positive``), where the
        law needs them.
    """

    name: str
    meaning: str
    unit: str
    scale: Callable[[Refs], float]
    positive: bool = False
    default: float | None = None
    bounds: tuple[float, float] | None = None
    smallest: float | None = None
    largest: float | None = None


class Grid(NamedTuple):
    """Values tried for a parameter besides the coefficient: ``fractions`` times the rms of
    the deformation (``variable`` ``"x"``) or of its rate (``"v"``).

    With ``per`` the grid value is the ratio ``param / per`` and ``per`` is the coefficient:
    a slider's force ``kd J(u; fd / kd)`` is linear in ``kd`` for a fixed slip displacement
    ``fd / kd``, so memory kinds are screened like memoryless ones. ``fixed`` parameters keep
    one value while screening (a hysteresis loop's sharpness).
    """

    param: str
    variable: str
    fractions: tuple[float, ...]
    per: str | None = None
    fixed: tuple[tuple[str, float], ...] = ()
    level: str = "low"
    """Whose rms the fractions scale: the lowest (``"low"``) or highest (``"high"``) level."""


@dataclass(frozen=True)
class Search:
    """How the diagnosis seeds a kind (`analysis.diagnose`).

    Attributes
    ----------
    grid : Grid, optional
        Kinds with a parameter besides the coefficient (or, with ``Grid.per``, memory kinds
        linear in one parameter at a fixed ratio of two): the values tried.
    starts : callable, optional
        Memory kinds: ``starts(k_w, u_amp)`` -> physical start points (in `Kind.params`
        order) from the linear stiffness at the location and the median deformation
        amplitude.
    inactive : callable, optional
        Memory kinds: ``inactive(params, u_max)`` is true when the fitted element never
        leaves its linear range in the data (then it is a stiffness error, not this kind).
    """

    grid: Grid | None = None
    starts: Callable[[float, float], list[list[float]]] | None = None
    inactive: Callable[[dict[str, float], float], bool] | None = None


@dataclass(frozen=True)
class Kind:
    """Descriptor of one element kind.

    Attributes
    ----------
    code : int
        Branch of the numba law (`analysis.models.element_force`).
    parameters : tuple of Param
    memory : bool
        Carries a state (hysteretic); not linear in its parameters.
    dissipative : bool
        Dissipates energy for a positive coefficient; a negative estimate is unphysical.
    coef : str, optional
        Memoryless kinds: the parameter the force is linear in, ``g = coef * b(u or u')``.
    basis : str, optional
        Name of ``b`` in `analysis.models.LIBRARY` or `analysis.models.FAMILIES`.
    basis_arg : str, optional
        Parameter passed to ``b`` (gap width, friction regularisation velocity).
    basis_label : str, optional
        Format of the basis name from the parameters (default: the library name).
    stiffness : callable, optional
        ``stiffness(params, u_max)``: largest tangent stiffness (N/m) over deformations up to
        ``u_max`` (0 before a run), for the plant's substep choice.
    damping : callable, optional
        ``damping(params, v_max)``: largest tangent damping (N s/m) over rates up to
        ``v_max``, likewise.
    search : Search
    initial_stiffness : str, optional
        Parameter that is the element's stiffness before it slips: a linear model fitted at
        a low level already holds it, so the diagnosis also offers the element with that
        stiffness taken out of the linear part.
    plant_restart : callable, optional
        ``plant_restart(state, params, g, v)``: sets the plant's extra state slots of an
        element restarted from a measured force ``g`` and rate ``v`` (in place).
    law, tangent : numba functions, optional
        Only for kinds registered at run time (see `analysis.models.register_kind`).
    """

    code: int
    parameters: tuple[Param, ...]
    memory: bool = False
    dissipative: bool = False
    coef: str | None = None
    basis: str | None = None
    basis_arg: str | None = None
    basis_label: str | None = None
    stiffness: Callable[[dict[str, float]], float] | None = None
    damping: Callable[[dict[str, float]], float] | None = None
    search: Search = Search()
    initial_stiffness: str | None = None
    plant_restart: Callable[[np.ndarray, dict[str, float], float, float], None] | None = None
    law: Any = None
    tangent: Any = None

    @property
    def params(self) -> tuple[str, ...]:
        """Required parameters."""
        return tuple(p.name for p in self.parameters if p.default is None)

    @property
    def optional(self) -> tuple[tuple[str, float], ...]:
        """Optional parameters and their defaults."""
        return tuple((p.name, p.default) for p in self.parameters if p.default is not None)

    @property
    def all_params(self) -> tuple[str, ...]:
        """Every parameter, in the packed order of the numba law."""
        return self.params + tuple(name for name, _ in self.optional)

    @property
    def positive(self) -> tuple[str, ...]:
        """Names of the parameters that must be positive."""
        return tuple(p.name for p in self.parameters if p.positive)

    def param(self, name: str) -> Param:
        """The parameter named ``name``.

        Parameters
        ----------
        name : str

        Returns
        -------
        Param
        """
        return next(p for p in self.parameters if p.name == name)

    def value(self, params: dict[str, float], name: str) -> float:
        """``params[name]``, or the parameter's default."""
        return params.get(name, self.param(name).default)


_V_REG = 1e-3      # default friction regularisation velocity, m/s


def _stiffness_scale(r: Refs) -> float:
    return r.k


def _force_scale(r: Refs) -> float:
    return 0.1 * r.f


def _slider_starts(*extra: float) -> Callable[[float, float], list[list[float]]]:
    """Starts of a slider kind: stiffness 0.3 and 3 times the linear one, slip force at
    0.1 and 0.5 of that stiffness times the amplitude, then ``extra``."""
    def starts(k_w: float, u_amp: float) -> list[list[float]]:
        return [[kd, kd * frac * u_amp, *extra] for kd in (0.3 * k_w, 3 * k_w)
                for frac in (0.1, 0.5)]
    return starts


def _slips_below(fraction: float) -> Callable[[dict[str, float], float], bool]:
    """The slider stays in its linear range when ``kd u_max < fraction fd``."""
    def inactive(p: dict[str, float], u_max: float) -> bool:
        return p["kd"] * u_max < fraction * p["fd"]
    return inactive


def _stick_slip_restart(state: np.ndarray, p: dict[str, float], g: float, v: float) -> None:
    """The plant keeps the slip direction (0 = sticking) in state slot 1."""
    slipping = abs(g) >= p["fd"] * (1 - 1e-9)
    state[1] = np.sign(v) if slipping else 0.0


_SLIP_FRACTIONS = (0.5, 1.0, 2.0, 4.0, 8.0)
"""Slip displacements ``fd / kd`` screened, in rms deformations at the lowest level (a
joint that sticks there and slips at the higher levels)."""

_KD = Param("kd", "stiffness", "N/m", _stiffness_scale, positive=True)
_FD = Param("fd", "slip force", "N", _force_scale, positive=True)

KINDS: dict[str, Kind] = {
    "cubic_spring": Kind(
        0, (Param("p", "coefficient", "N/m³", lambda r: r.k / r.u ** 2),),
        coef="p", basis="x^3", stiffness=lambda p, u: max(3.0 * p["p"] * u ** 2, 0.0)),
    "quadratic_spring": Kind(
        1, (Param("p", "coefficient", "N/m²", lambda r: r.k / r.u),),
        coef="p", basis="x|x|", stiffness=lambda p, u: 2.0 * abs(p["p"]) * u),
    "quadratic_damping": Kind(
        2, (Param("p", "coefficient", "N·s²/m²", lambda r: r.c * (1 / r.v)),),
        dissipative=True, coef="p", basis="v|v|", damping=lambda p, v: 2.0 * abs(p["p"]) * v),
    "cubic_damping": Kind(
        3, (Param("p", "coefficient", "N·s³/m³", lambda r: r.c * (1 / r.v ** 2)),),
        dissipative=True, coef="p", basis="v^3",
        damping=lambda p, v: 3.0 * abs(p["p"]) * v ** 2),
    "coulomb_friction": Kind(
        4, (Param("fc", "friction force", "N", _force_scale),
            Param("v_reg", "regularisation velocity", "m/s", lambda r: 0.01 * r.v,
                  positive=True, default=_V_REG)),
        dissipative=True, coef="fc", basis="sign(v)", basis_arg="v_reg",
        damping=lambda p, v: abs(p["fc"]) / p.get("v_reg", _V_REG),
        search=Search(grid=Grid("v_reg", "v", (0.01,)))),
    "stick_slip": Kind(
        5, (_KD, _FD), memory=True, stiffness=lambda p, u: p["kd"],
        search=Search(grid=Grid("fd", "x", _SLIP_FRACTIONS, per="kd"),
                      starts=_slider_starts(), inactive=_slips_below(1.0)),
        initial_stiffness="kd", plant_restart=_stick_slip_restart),
    "hysteresis": Kind(
        6, (_KD, _FD, Param("n", "sharpness exponent", "-", lambda r: 2.0, positive=True,
                            bounds=(0.5, 1000.0), smallest=0.01)),
        memory=True, stiffness=lambda p, u: p["kd"],
        search=Search(grid=Grid("fd", "x", _SLIP_FRACTIONS, per="kd", fixed=(("n", 2.0),)),
                      starts=_slider_starts(2.0), inactive=_slips_below(0.5)),
        initial_stiffness="kd"),
    "iwan": Kind(
        8, (_KD, _FD,
            Param("chi", "slider-strength exponent", "-", lambda r: 0.5, bounds=(-0.95, 0.9),
                  smallest=-0.99, largest=10.0),
            Param("beta", "full-slip share", "-", lambda r: 0.5, bounds=(0.0, 10.0),
                  smallest=0.0, largest=1e6)),
        memory=True, stiffness=lambda p, u: p["kd"],
        search=Search(grid=Grid("fd", "x", _SLIP_FRACTIONS, per="kd",
                                fixed=(("chi", -0.5), ("beta", 0.5))),
                      starts=_slider_starts(-0.5, 0.5), inactive=_slips_below(0.5)),
        initial_stiffness="kd"),
    "gap": Kind(
        7, (Param("k", "contact stiffness", "N/m", _stiffness_scale, positive=True),
            Param("g", "width", "m", lambda r: 0.5 * r.u, positive=True)),
        coef="k", basis="gap", basis_arg="g", basis_label="gap({g:g})",
        stiffness=lambda p, u: max(p["k"], 0.0),
        search=Search(grid=Grid("g", "x", (0.25, 0.5, 1.0, 2.0, 3.0), level="high"))),
}
"""Every element kind (the built-in ones are the branches of the numba law)."""


def lookup(name: str) -> Kind:
    """The descriptor of kind ``name``; `InputError` naming the known kinds otherwise."""
    try:
        return KINDS[name]
    except KeyError:
        raise InputError(f"element kind '{name}' is unknown; use one of "
                         f"{', '.join(KINDS)}") from None


def search_order() -> tuple[str, ...]:
    """Kinds in the diagnosis library's order: restoring, dissipative, memory kinds."""
    return tuple(sorted(KINDS, key=lambda k: (KINDS[k].memory, KINDS[k].dissipative)))


def coefficient_units() -> dict[str, str]:
    """Unit of the basis coefficient of each kind linear in one parameter."""
    return {name: k.param(k.coef).unit for name, k in KINDS.items() if k.coef is not None}
