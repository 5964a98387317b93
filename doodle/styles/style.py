"""Styles as data: one table of defaults, merged with a TOML (or JSON) file into a validated :class:`Style`.

Built-in styles are TOML files in ``builtin/`` written in the same format a user writes. Lengths are in
pixels, widths are multiples of the stroke file's ``width_px``.
"""

from __future__ import annotations

import functools
import json
import math
import re
import sys
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from ..errors import DoodleError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

_HEX = re.compile(r"^#[0-9a-fA-F]{6}$")


@dataclass(frozen=True)
class LineStyle:
    color: str = "#141414"
    width: float = 1.0
    """Multiple of the stroke file's ``width_px``."""
    silhouette_width: float = 1.0
    """Extra factor for superquadric silhouettes (outlines read better a little heavier)."""
    opacity: float = 1.0
    passes: int = 1
    """Strokes drawn per path, each with its own jitter (pencil, sketchy, charcoal)."""
    jitter: float = 0.0
    """Amplitude (px) of the smooth sideways wobble of each pass."""
    jitter_waves: float = 2.0
    """How many wobbles along a stroke."""
    overshoot: float = 0.0
    """How far (px) passes run past the stroke's ends."""
    roughness: float = 0.0
    """Amplitude (px) of fine, scratchy wobble."""
    taper: float = 0.0
    """Fraction of the length over which each end thins to a point (filled outlines when > 0)."""
    width_variation: float = 0.0
    """Relative swelling of the width along the stroke (filled outlines when > 0)."""
    dash: tuple[float, ...] = ()
    """Dash pattern in multiples of the line width."""
    blend: str = "normal"
    linecap: str = "round"


@dataclass(frozen=True)
class HiddenStyle:
    color: str = "#8c8c8c"
    opacity: float = 1.0
    dash: tuple[float, ...] = (4.0, 3.0)


@dataclass(frozen=True)
class FilterStyle:
    grain: float = 0.0
    """Strength of an SVG turbulence filter that roughens edges (SVG viewers only; off with --no-filters)."""


@dataclass(frozen=True)
class Style:
    name: str = "ink"
    description: str = ""
    background: str = "#ffffff"
    """Hex colour or ``none``."""
    hidden_mode: str = ""
    """Preferred ``--hidden`` mode when the user gives none ("" = the command's default)."""
    seed: int = 1
    line: LineStyle = field(default_factory=LineStyle)
    hidden: HiddenStyle = field(default_factory=HiddenStyle)
    filter: FilterStyle = field(default_factory=FilterStyle)

    @property
    def is_plain(self) -> bool:
        """True when paths can be written as exact cubics (no per-stroke geometry changes)."""
        ln = self.line
        return ln.passes == 1 and not (ln.jitter or ln.overshoot or ln.roughness or ln.taper or ln.width_variation)


_SECTIONS = {"line": LineStyle, "hidden": HiddenStyle, "filter": FilterStyle}
_RANGES = {
    "width": (0.01, 50), "silhouette_width": (0.01, 10), "opacity": (0.0, 1.0), "passes": (1, 12),
    "jitter": (0, 50), "jitter_waves": (0.1, 50), "overshoot": (0, 100), "roughness": (0, 20), "taper": (0, 0.5),
    "width_variation": (0, 1), "grain": (0, 1), "seed": (0, 2**31 - 1),
}
_CHOICES = {"blend": ("normal", "multiply"), "linecap": ("round", "butt", "square"), "hidden_mode": ("", "hide", "dash", "show")}


def _short(value: Any) -> str:
    """``repr`` cut to 40 characters: error messages stay one readable line whatever the file holds."""
    text = repr(value) if not (isinstance(value, int) and abs(value) > 10**15) else "a huge integer"
    return text if len(text) <= 40 else text[:37] + "..."


def _finite(v: Any) -> bool:
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


def _check(value: Any, default: Any, name: str, source: str) -> Any:
    key = name.rsplit(".", 1)[-1]
    where = f"{source}: {name}"
    if isinstance(default, bool):
        raise AssertionError
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise DoodleError(f"{where}: expected an integer, got {_short(value)}")
    elif isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not _finite(value):
            raise DoodleError(f"{where}: expected a finite number, got {_short(value)}")
        value = float(value)
    elif isinstance(default, tuple):
        if (not isinstance(value, list) or len(value) > 64
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and _finite(v) and v > 0 for v in value)):
            raise DoodleError(f"{where}: expected a list of up to 64 positive numbers, got {_short(value)}")
        return tuple(float(v) for v in value)
    elif isinstance(default, str):
        if not isinstance(value, str):
            raise DoodleError(f"{where}: expected a string, got {_short(value)}")
    if key in _RANGES:
        lo, hi = _RANGES[key]
        if not lo <= value <= hi:
            raise DoodleError(f"{where}: {_short(value)} outside [{lo}, {hi}]")
    if key in _CHOICES and value not in _CHOICES[key]:
        raise DoodleError(f"{where}: {_short(value)} is not one of {', '.join(repr(c) for c in _CHOICES[key])}")
    if key == "color" and not _HEX.match(value):
        raise DoodleError(f"{where}: expected a hex colour like #1a2b3c, got {_short(value)}")
    if key == "background" and value != "none" and not _HEX.match(value):
        raise DoodleError(f"{where}: expected a hex colour like #ffffff or 'none', got {_short(value)}")
    return value


def style_from_dict(data: Any, source: str = "<style>") -> Style:
    """Merge a style document over the defaults; unknown keys and bad values raise :class:`DoodleError`."""
    if not isinstance(data, dict):
        raise DoodleError(f"{source}: a style is a table of settings")
    base = Style()
    top: dict[str, Any] = {}
    for key, value in data.items():
        if key in _SECTIONS:
            if not isinstance(value, dict):
                raise DoodleError(f"{source}: {key}: expected a table")
            defaults = _SECTIONS[key]()
            known = {f: getattr(defaults, f) for f in defaults.__dataclass_fields__}
            fields = {}
            for k, v in value.items():
                if k not in known:
                    raise DoodleError(f"{source}: {key}.{k}: unknown setting (known: {', '.join(known)})")
                fields[k] = _check(v, known[k], f"{key}.{k}", source)
            top[key] = _SECTIONS[key](**fields)
        elif key in ("name", "description", "background", "hidden_mode", "seed"):
            top[key] = _check(value, getattr(base, key), key, source)
        else:
            raise DoodleError(f"{source}: {key}: unknown setting (known: name, description, background, "
                              f"hidden_mode, seed, [line], [hidden], [filter])")
    return Style(**top)


def _builtin_dir():
    return resources.files("doodle.styles") / "builtin"


@functools.lru_cache(maxsize=1)
def _builtin_names() -> tuple[str, ...]:
    return tuple(sorted(p.name[:-5] for p in _builtin_dir().iterdir() if p.name.endswith(".toml")))


def builtin_names() -> list[str]:
    return list(_builtin_names())


@functools.lru_cache(maxsize=None)
def _builtin_style(name: str) -> Style:
    # Parsed once per process: every view, frame and preview without an explicit style draws with "ink".
    res = _builtin_dir() / f"{name}.toml"
    return style_from_dict(tomllib.loads(res.read_text(encoding="utf-8")), f"built-in style {name}")


MAX_STYLE_BYTES = 1 << 20


def load_style(name_or_path: str | Path) -> Style:
    """A built-in style by name, or a ``.toml`` / ``.json`` style file."""
    text_name = str(name_or_path)
    if text_name in _builtin_names():
        return _builtin_style(text_name)
    path = Path(text_name)
    if path.suffix.lower() not in (".toml", ".json") or not path.exists():
        if path.suffix.lower() in (".toml", ".json"):
            raise DoodleError(f"{path}: style file not found")
        raise DoodleError(f"unknown style {text_name!r} (built-in: {', '.join(builtin_names())}; or a .toml/.json file)")
    if not path.is_file():
        raise DoodleError(f"{path}: not a regular file")
    try:
        if path.stat().st_size > MAX_STYLE_BYTES:
            raise DoodleError(f"{path}: style file larger than {MAX_STYLE_BYTES} bytes")
        text = path.read_text(encoding="utf-8")
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (OSError, UnicodeDecodeError) as exc:
        raise DoodleError(f"{path}: cannot read style ({getattr(exc, 'strerror', None) or exc})") from None
    except (tomllib.TOMLDecodeError, ValueError) as exc:  # JSONDecodeError is a ValueError
        raise DoodleError(f"{path}: not valid {path.suffix[1:].upper()} ({str(exc).splitlines()[0][:80]})") from None
    except RecursionError:
        raise DoodleError(f"{path}: nested too deeply") from None
    if not isinstance(data, dict):
        raise DoodleError(f"{path}: a style is a table of settings, not a {type(data).__name__}")
    data.setdefault("name", path.stem)
    return style_from_dict(data, str(path))
