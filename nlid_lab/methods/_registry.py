"""The estimator registry: what `analyze`, `reanalyze`, `report` and `view` know of a method.

A `Method` bundles an estimator's name, its options (a dataclass whose `option` fields carry
their command-line flags), its estimate function on recordings, how one level is estimated in a
batch reanalysis, and its report sections. `register` adds one; nothing else in the
application names an estimator. Stored and JSON results carry ``"estimator": <name>``;
results stored before that key existed are recognised by their keys (`Method.legacy_keys`).
What leaves the registry is typed: a run's stored results come back as `StoredResult`s (the
method's `StoredEstimate` inside), `reanalyze`'s options as `BatchOptions`; the JSON is read
only by the `from_json` of a method's result type.

Every command line builds all parsers, so a method module imports only this registry at the
top; numerics, figures and the store are imported inside its functions.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Mapping, Protocol, Sequence

from analysis.documents import JsonObject
from analysis.errors import InputError
from analysis.recordings import Excitation

from ..plugins import discover

if TYPE_CHECKING:
    from analysis.models import Model
    from analysis.recordings import Recording

    from ..store import EstimatedElement

#: Key naming the estimator in a method's JSON and stored result.
ESTIMATOR_KEY = "estimator"


class LevelEstimate(Protocol):
    """What a method's one-level estimate (reanalysis) returns."""

    def to_json(self) -> dict[str, Any]:
        """The JSON / stored result (contracts section 4), with ``"estimator"``."""


@dataclass(frozen=True)
class StoredEstimate:
    """An estimator's JSON / stored result read back typed: what every method's result says.

    Each method reads its own layout with its `Method.result` type (a subclass adding what
    that estimator reports); this base reads the fields every layout has, old runs included
    (elements without ``"estimated"``: `nlid_lab.store.EstimatedElement`).

    Attributes
    ----------
    elements : tuple of EstimatedElement
        The estimated elements (kind, w, parameters, 95 % intervals, which were estimated).
    warnings : tuple of str
        What the estimator warned of.
    coherence_min : float or None
        Lowest multiple coherence of the estimate (estimators that report one).
    cost : float or None
        Final cost of a fit (estimators that minimise one).
    """

    elements: tuple[EstimatedElement, ...]
    warnings: tuple[str, ...] = ()
    coherence_min: float | None = None
    cost: float | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> StoredEstimate:
        """The fields every estimator's JSON has (``elements``, ``warnings``); a subclass
        reads its own fields into ``super().from_json(data)`` (`dataclasses.replace`)."""
        from ..store import elements_from_json   # h5py: the store loads on use (module doc)
        return cls(elements_from_json(data), tuple(str(w) for w in data.get("warnings") or ()))


@dataclass(frozen=True)
class StoredResult:
    """A method's result as a run stores it, found and read back typed (`find_stored`).

    Attributes
    ----------
    name : str
        Name the run stores it under (``analyze-<method>``, or an older name).
    method : str
        The method whose result it is (`Method.name`).
    estimate : StoredEstimate
        The result read by the method's `Method.result` type.
    """

    name: str
    method: str
    estimate: StoredEstimate

    @property
    def elements(self) -> tuple[EstimatedElement, ...]:
        """The estimate's elements (what the report's table of stored estimates lists)."""
        return self.estimate.elements


@dataclass(frozen=True)
class BatchOptions:
    """The batch options `reanalyze` was given (`batch_values`): option field name -> value,
    None where not given (the method's default then applies). Each method builds its typed
    options from them (`Method.make_options`); names of other methods' options are ignored.
    """

    values: tuple[tuple[str, object], ...] = ()

    @classmethod
    def of(cls, **values: object) -> BatchOptions:
        """Options by keyword (a script's or test's `reanalyze`)."""
        return cls(tuple(values.items()))

    def get(self, name: str) -> object:
        """The value given for option ``name`` (None when not given)."""
        return dict(self.values).get(name)

    def to_json(self) -> JsonObject:
        """The options as stored with a reanalysis table (its ``options`` attribute)."""
        return dict(self.values)


class Estimate(LevelEstimate, Protocol):
    """What a method's estimate function returns."""

    def table(self) -> str:
        """A readable summary for the terminal."""

    def write_files(self) -> list[str]:
        """Further output files the options asked for (figures); their paths."""


def option(*flags: str, default: Any = None, batch: bool = False, **argparse_kwargs: Any
           ) -> Any:
    """A field of a method's options dataclass together with its command-line flag.

    Parameters
    ----------
    *flags : str
        Option strings, e.g. ``"--band"``; the field name is the argparse ``dest``.
    default : object
        Default of the field and of `analyze`'s option.
    batch : bool
        Also offered by `reanalyze` (one level at a time, no files written).
    **argparse_kwargs
        Passed to `argparse.ArgumentParser.add_argument` (``help``, ``type``, ``choices``,
        ``nargs``, ``metavar``, ``action``).
    """
    return field(default=default, metadata={"flags": flags, "batch": batch,
                                            "argparse": argparse_kwargs})


@dataclass(frozen=True)
class Method:
    """One estimator.

    Attributes
    ----------
    name : str
        ``analyze`` sub-command, ``reanalyze --method`` value and the ``"estimator"`` of its
        results; stored into runs as ``analyze-<name>``.
    help : str
        One line for ``analyze --help``.
    options : type
        Dataclass of the method's settings; its `option` fields are the command-line flags.
    excitation : Excitation
        Excitation of the levels it estimates from (``reanalyze --method auto`` picks the first
        registered method matching a level).
    estimate : callable
        ``estimate(recordings, model, options) -> Estimate``: all given levels together.
    estimate_level : callable, optional
        ``estimate_level(recording, model, options) -> LevelEstimate``: one level for
        `reanalyze`; default ``estimate([recording], model, options)``.
    sections : callable, optional
        ``sections(run, frfs, stored, candidate) -> list[Section]``: report sections, given the
        run (`nlid_lab.reports.RunData`), its level FRFs, the method's latest stored result
        (`StoredResult`, or None) and the candidate model asked for (or None).
    legacy_keys : tuple of str
        A stored result without ``"estimator"`` holding all these keys is this method's.
    output_files : callable, optional
        ``output_files(options) -> list of paths``: the files its estimate writes (figures),
        checked against overwriting before any work.
    result : type
        `StoredEstimate` or the method's subclass of it: its ``from_json`` reads the method's
        JSON and stored results (old layouts too) back typed (`find_stored`, the reanalysis
        rows).
    """

    name: str
    help: str
    options: type
    excitation: Excitation
    estimate: Callable[[Sequence[Recording], Model, Any], Estimate]
    estimate_level: Callable[[Recording, Model, Any], LevelEstimate] | None = None
    sections: Callable[..., list[Any]] | None = None
    legacy_keys: tuple[str, ...] = ()
    output_files: Callable[[Any], list[str]] | None = None
    result: type[StoredEstimate] = StoredEstimate

    @property
    def result_name(self) -> str:
        """Name of the result `analyze --store` saves into a run."""
        return f"analyze-{self.name}"

    def option_fields(self, batch_only: bool = False) -> list[dataclasses.Field]:
        """The options fields that are command-line flags (with ``batch_only``, those
        ``reanalyze`` takes too)."""
        return [f for f in dataclasses.fields(self.options)
                if "flags" in f.metadata and (f.metadata["batch"] or not batch_only)]

    def make_options(self, given: argparse.Namespace | BatchOptions) -> Any:
        """The options dataclass from the parsed ``analyze`` arguments or `reanalyze`'s
        `BatchOptions` (None or missing names take the default). Lists become tuples
        (argparse ``nargs``)."""
        values = dict(given.values) if isinstance(given, BatchOptions) else vars(given)
        names = {f.name for f in dataclasses.fields(self.options)}
        kept = {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()
                if k in names and v is not None}
        return self.options(**kept)

    def estimate_one(self, rec: Recording, model: Model, options: Any) -> LevelEstimate:
        """One level's estimate (reanalysis): `estimate_level`, else `estimate` of it alone."""
        if self.estimate_level is not None:
            return self.estimate_level(rec, model, options)
        return self.estimate([rec], model, options)

    def owns(self, result: Any) -> bool:
        """Whether a stored result is this method's (by ``"estimator"``, else its keys)."""
        if not isinstance(result, dict):
            return False
        if ESTIMATOR_KEY in result:
            return result[ESTIMATOR_KEY] == self.name
        return bool(self.legacy_keys) and all(k in result for k in self.legacy_keys)


_METHODS: dict[str, Method] = {}


def register(method: Method) -> Method:
    """Add ``method`` (replacing one of the same name); returns it."""
    _METHODS[method.name] = method
    return method


def unregister(name: str) -> None:
    """Remove a method (tests registering a toy method clean up with this)."""
    _METHODS.pop(name, None)


def methods() -> list[Method]:
    """Registered methods, in registration order."""
    return list(_METHODS.values())


def get(name: str) -> Method:
    """The method called ``name``; `InputError` naming the known ones otherwise."""
    try:
        return _METHODS[name]
    except KeyError:
        raise InputError(f"unknown method '{name}'; use one of {', '.join(_METHODS)}") \
            from None


def for_excitation(excitation: str | None) -> Method:
    """The first registered method estimating from ``excitation`` levels."""
    for method in _METHODS.values():
        if method.excitation == excitation:
            return method
    raise InputError(f"no estimator takes {excitation} levels; choose --method explicitly")


def find_stored(results: Mapping[str, object], method: Method) -> StoredResult | None:
    """The last of a run's stored ``results`` (name -> what the store read) that is
    ``method``'s, read back typed; None when there is none."""
    found = None
    for name, res in results.items():
        if method.owns(res):
            found = name, res
    return None if found is None else _stored(found[0], found[1], method)


def stored_estimates(results: Mapping[str, object]) -> list[StoredResult]:
    """The stored results of any registered method, in stored order, read back typed."""
    out = []
    for name, res in results.items():
        method = next((m for m in _METHODS.values() if m.owns(res)), None)
        if method is not None:
            out.append(_stored(name, res, method))
    return out


def _stored(name: str, result: object, method: Method) -> StoredResult:
    """A stored result `Method.owns` found (a JSON object), read by the method's type."""
    return StoredResult(name, method.name, method.result.from_json(result))


# --- command-line options ------------------------------------------------------------------
def add_options(parser: argparse.ArgumentParser, method: Method) -> None:
    """Add every option of ``method`` to its ``analyze`` sub-command parser."""
    for f in method.option_fields():
        kwargs = dict(f.metadata["argparse"])
        if f.default is not None and kwargs.get("action") != "store_true":
            kwargs["default"] = f.default
        parser.add_argument(*f.metadata["flags"], dest=f.name, **kwargs)


def add_batch_options(parser: argparse.ArgumentParser) -> None:
    """Add the batch options of every method to the ``reanalyze`` parser, once each.

    Defaults are left to the method (None here), so the stored options name what was given.
    """
    seen: set[str] = set()
    for method in _METHODS.values():
        for f in method.option_fields(batch_only=True):
            if f.name in seen:      # an option two methods share: the first one's help
                continue
            seen.add(f.name)
            kwargs = dict(f.metadata["argparse"])
            kwargs["help"] = f"{method.name}: {kwargs.get('help', '')}"
            parser.add_argument(*f.metadata["flags"], dest=f.name, **kwargs)


def batch_values(args: argparse.Namespace) -> BatchOptions:
    """The batch options given to ``reanalyze``, every method's (None where not given)."""
    out: dict[str, object] = {}
    for method in _METHODS.values():
        for f in method.option_fields(batch_only=True):
            value = getattr(args, f.name, None)
            out[f.name] = tuple(value) if isinstance(value, list) else value
    return BatchOptions(tuple(out.items()))
