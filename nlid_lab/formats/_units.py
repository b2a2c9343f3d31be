"""Engineering units of measured channels: scale to SI and the quantity they imply.

Acquisition exports label channels ``Force (N)``, ``Acc1 [m/s^2]``, ``a_tip [g]``: the unit
names what was measured (force, or which response kind) and how to scale it to SI.
"""

from __future__ import annotations

import re

from analysis.errors import InputError

G0 = 9.80665

#: unit -> (factor to SI, quantity)
UNITS: dict[str, tuple[float, str]] = {
    "N": (1.0, "force"), "kN": (1e3, "force"), "mN": (1e-3, "force"),
    "lbf": (4.4482216152605, "force"),
    "m": (1.0, "displacement"), "mm": (1e-3, "displacement"), "um": (1e-6, "displacement"),
    "µm": (1e-6, "displacement"), "in": (0.0254, "displacement"),
    "m/s": (1.0, "velocity"), "mm/s": (1e-3, "velocity"), "in/s": (0.0254, "velocity"),
    "m/s^2": (1.0, "acceleration"), "m/s2": (1.0, "acceleration"),
    "m/s²": (1.0, "acceleration"), "mm/s^2": (1e-3, "acceleration"),
    "g": (G0, "acceleration"), "mg": (1e-3 * G0, "acceleration"),
    "s": (1.0, "time"), "ms": (1e-3, "time"),
}
#: voltage units: a circuit's input and output (the Silverbox), or a sensor before its
#: sensitivity; refused with the way to read such channels as they are
VOLTS = ("v", "mv", "uv", "µv")
_FOLD = {name.lower(): name for name in UNITS}
_LABEL = re.compile(r"^\s*(?P<name>.*?)\s*[\(\[]\s*(?P<unit>[^\)\]]+?)\s*[\)\]]\s*$")


def lookup(unit: str, where: str) -> tuple[float, str]:
    """Factor to SI and quantity of ``unit`` (case-insensitive except ``mN``/``m``/``g``...)."""
    key = unit.strip()
    if key not in UNITS:
        key = _FOLD.get(key.lower(), key)
    if key.lower() in VOLTS:
        raise InputError(f"{where}: '{unit}' is a voltage, not a force or a motion; map the "
                         "channel without a unit (read in the file's own units: the force as "
                         "N, a response as a displacement, e.g. force=V1 response=V2)")
    if key not in UNITS:
        raise InputError(f"{where}: unknown unit '{unit}'; use one of {', '.join(UNITS)}")
    return UNITS[key]


def split_label(label: str) -> tuple[str, str | None]:
    """``"Acc1 [m/s^2]"`` -> ``("Acc1", "m/s^2")``; a label without a unit -> ``(label, None)``."""
    m = _LABEL.match(label)
    return (m["name"], m["unit"]) if m else (label.strip(), None)


def kind_of_name(name: str) -> str | None:
    """The response kind a variable's name states (``Acceleration``, ``acc2``, ``Vel``,
    ``Disp``), or None: exports name channels so more often than they give a unit."""
    last = name.rpartition(".")[2].lower()
    for prefix, kind in (("acc", "acceleration"), ("vel", "velocity"), ("disp", "displacement")):
        if last.startswith(prefix):
            return kind
    return None
