"""Planning a study: the ``--vary`` arguments, their combinations, run names, and which scene
keys order runs from coarse to fine.

* :class:`Vary`, :func:`parse_vary`, :func:`split_values`: ``--vary KEY=V1,V2,...``;
* :func:`combinations`, :func:`run_label`, :func:`run_name`: the runs of a study, in order;
* :data:`ORDERED_KEYS`, :func:`order_sign`, :func:`ordered_varies`: discretisation keys
  (fnmatch patterns, from the schema) and the direction in which they refine; :data:`RICHARDSON_KEYS`: the keys
  along which a Richardson extrapolation is made, with the mesh size h(value);
* :data:`UNORDERED_KEYS`: discretisation keys that do not order runs (a mesh's grading);
* :func:`set_key`, :func:`non_discretisation_keys`: the keys a study changes that are not
  discretisation keys (the published references no longer apply when there is one);
* :func:`study_command`: the equivalent ``fenics-plast study`` command line (shown in study.md).

Nothing here runs anything or reads a scene file.
"""
from __future__ import annotations

import fnmatch
import itertools
import re
import shlex
import tomllib
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Sequence

from ..schema import discretisation_keys

#: Keys (fnmatch patterns) that order runs from coarse to fine: +1 = a larger value is finer,
#: -1 = a smaller one. The first pattern that matches a key gives its direction. Declared in the
#: schema (``Key.refines``, :func:`fenics_plast.schema.discretisation_keys`).
ORDERED_KEYS: dict[str, int] = {k: r for k, (r, _axis) in discretisation_keys().items() if r != 0}

#: Discretisation keys (fnmatch patterns) that do not order runs: a mesh's grading, the stable-step
#: estimate (``Key.refines = 0`` in the schema). Categorical in a study (each value its own group), but
#: like :data:`ORDERED_KEYS` they leave the problem itself, and so its published references, unchanged.
UNORDERED_KEYS: tuple[str, ...] = tuple(k for k, (r, _axis) in discretisation_keys().items() if r == 0)

#: Keys (fnmatch patterns) along which a Richardson extrapolation is made, with the mesh size h(value).
RICHARDSON_KEYS: dict[str, Callable[[float], float]] = {"mesh.refine": lambda v: 1.0 / v}


class StudyError(ValueError):
    """Bad study arguments (exit status 2)."""


def _match(key: str, table: dict):
    for pattern, value in table.items():
        if fnmatch.fnmatchcase(key, pattern):
            return value
    return None


def order_sign(key: str) -> int | None:
    """+1 (larger is finer), -1 (smaller is finer) or None (not a discretisation key)."""
    return _match(key, ORDERED_KEYS)


def mesh_size(key: str) -> Callable[[float], float] | None:
    """h(value) of a Richardson key; None when no extrapolation is made along ``key``."""
    return _match(key, RICHARDSON_KEYS)


@dataclass
class Vary:
    """One ``--vary KEY=V1,V2,...``: the dotted scene key and its values as ``--set`` text."""
    key: str
    values: list[str]

    @property
    def short(self) -> str:
        return self.key.rsplit(".", 1)[-1]

    @property
    def sign(self) -> int | None:
        """Direction of refinement (see :func:`order_sign`)."""
        return order_sign(self.key)


def split_values(text: str) -> list[str]:
    """Split ``V1,V2,...`` on the commas outside brackets and quotes (TOML lists and strings)."""
    out, depth, quote, cur = [], 0, None, []
    for ch in text:
        if quote:
            cur.append(ch)
            if ch == quote:
                quote = None
            continue
        if ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append("".join(cur).strip())
            cur = []
            continue
        cur.append(ch)
    out.append("".join(cur).strip())
    return out


def parse_vary(text: str) -> Vary:
    """``"mesh.refine=1,2,4"`` -> ``Vary("mesh.refine", ["1", "2", "4"])``; StudyError if malformed."""
    if "=" not in text:
        raise StudyError(f"--vary {text!r} must have the form section.key=V1,V2,...")
    key, values = (s.strip() for s in text.split("=", 1))
    parts = key.split(".")
    if len(parts) < 2 or any(not p for p in parts):
        raise StudyError(f"--vary {text!r}: {key!r} must be a dotted key such as mesh.refine")
    vals = split_values(values)
    if any(v == "" for v in vals):
        raise StudyError(f"--vary {text!r}: empty value in the list")
    if len(set(vals)) != len(vals):
        raise StudyError(f"--vary {text!r}: a value is repeated")
    return Vary(key, vals)


def toml_value(text: str) -> Any:
    """The value ``--set`` would see: TOML, else the text itself."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def as_number(text: str) -> float | None:
    """The value of ``text`` as a float, or None when it is not a number (booleans are not)."""
    v = toml_value(text)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v)


def ordered_varies(varies: Sequence[Vary]) -> list[Vary]:
    """The varied keys that order runs from coarse to fine (numeric values only)."""
    return [v for v in varies if v.sign is not None and all(as_number(x) is not None for x in v.values)]


def set_key(text: str) -> str:
    """The dotted key of a ``--set KEY=VALUE``."""
    return text.split("=", 1)[0].strip()


def non_discretisation_keys(varies: Sequence[Vary], sets: Iterable[str]) -> list[str]:
    """The keys varied or ``--set`` that are not discretisation keys (:data:`ORDERED_KEYS`,
    :data:`UNORDERED_KEYS`), in order."""
    keys = [v.key for v in varies] + [set_key(s) for s in sets]
    return list(dict.fromkeys(k for k in keys if order_sign(k) is None
                              and not any(fnmatch.fnmatchcase(k, p) for p in UNORDERED_KEYS)))


def combinations(varies: Sequence[Vary]) -> list[dict[str, str]]:
    """Cartesian product of the values, the first ``--vary`` varying slowest."""
    return [dict(zip([v.key for v in varies], combo)) for combo in
            itertools.product(*[v.values for v in varies])]


def run_label(combo: dict[str, str], varies: Sequence[Vary]) -> str:
    """Short human label, e.g. ``refine=2 dt_safety=0.5``."""
    shorts = [v.short for v in varies]
    dup = {s for s in shorts if shorts.count(s) > 1}
    return " ".join(f"{v.key if v.short in dup else v.short}={combo[v.key]}" for v in varies) or "base"


def run_name(index: int, combo: dict[str, str], varies: Sequence[Vary]) -> str:
    """Directory name of run ``index`` (0-based): ``01_refine-2_dt_safety-0.5``."""
    label = run_label(combo, varies).replace("=", "-").replace(" ", "_")
    label = re.sub(r"[^A-Za-z0-9_.+-]", "-", label)[:80]
    return f"{index + 1:02d}_{label}"


def study_command(scene: str, varies: Sequence[Vary], sets: Sequence[str], out: str | None, np_ranks: int,
                  results: str | None = None, trust_mesh_script: bool = False) -> str:
    """The ``fenics-plast study`` command line of a study (quoted for a shell)."""
    parts = ["fenics-plast", "study", scene]
    for v in varies:
        parts += ["--vary", f"{v.key}={','.join(v.values)}"]
    for s in sets:
        parts += ["--set", s]
    if results:
        parts += ["--results", results]
    if np_ranks > 1:
        parts += ["--np", str(np_ranks)]
    if out:
        parts += ["--out", out]
    if trust_mesh_script:
        parts += ["--trust-mesh-script"]
    return " ".join(shlex.quote(p) for p in parts)
