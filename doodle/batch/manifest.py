"""The batch manifest: which scenes to turn into sketches, with which options (TOML, JSON or CSV).

TOML (JSON has the same shape)::

    [defaults]                # options for every object (any key below)
    detail = "low"
    gif = true

    [[objects]]
    scene = "scans/cow"       # a folder load_scene reads (photos too); relative to the manifest
    name = "cow"              # its output folder (default: the scene folder's name)
    views = 12                # per-object options override the defaults

CSV: a header row with ``scene``, optionally ``name`` and any option as a column; an empty cell takes the
default. A bad manifest (syntax, an unknown option, a value of the wrong kind, two objects of one name) is
refused as a whole, naming the file and the object; a scene that is missing or unreadable is not the
manifest's fault: that object fails alone when its turn comes.
"""

from __future__ import annotations

import csv
import json
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import DoodleError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


@dataclass(frozen=True)
class Option:
    """One per-object option: its kind (``int``, ``float``, ``bool``, ``str``, ``"count"``: a number or ``auto``,
    or a tuple of the allowed words), its default, what it does, and the bounds of a number."""

    kind: Any
    default: Any
    help: str
    limits: tuple[float, float] | None = None


def _fit_options() -> dict[str, Option]:
    """The fit's options, from :class:`~doodle.fit.config.FitConfig`'s declarations (``fit_size`` for its
    ``size``): a manifest takes every option ``doodle fit`` takes but the run's own (device, previews)."""
    from ..fit.config import config_fields, manifest_key

    return {manifest_key(f): Option(f.metadata["kind"], f.default, f.metadata["help"], f.metadata["limits"])
            for f in config_fields() if f.metadata["manifest"]}


#: Every per-object option, in the order of the stages that use it (fit, export, animate, view, eval).
OPTIONS: dict[str, Option] = {
    **_fit_options(),
    "split": Option(str, "train", "dataset split to fit"),
    "masks": Option(str, "auto", "auto, none or a folder of masks (relative to the manifest)"),
    "binary": Option(bool, True, "write strokes.doodleb (binary) rather than strokes.doodle (JSON)"),
    "views": Option(int, 36, "orbit views exported as SVG (0: none)", (0, 1000)),
    "size": Option(int, 512, "size of the exported views and of the viewer's, px", (16, 4096)),
    "style": Option(str, "ink", "brush style: a built-in name or a style file (relative to the manifest)"),
    "hidden": Option(("", "hide", "dash", "show"), "", "hidden lines (\"\": the style's, else hide)"),
    "png": Option(bool, False, "also write a PNG of every view"),
    "gif": Option(bool, True, "write turntable.gif"),
    "frames": Option(int, 36, "frames of the turntable", (1, 1000)),
    "gif_size": Option(int, 384, "size of the turntable, px", (16, 4096)),
    "html": Option(bool, False, "write sketch.html, the offline viewer (doodle view)"),
    "model3d": Option(("", "obj", "ply", "glb"), "", "also write the 3D strokes as strokes.obj/.ply/.glb (doodle export3d)"),
    "eval": Option(("auto", "yes", "no"), "auto", "score on the scene's held-out views (auto: when it has a test split)"),
}

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,99}$")


@dataclass
class BatchObject:
    """One object of the manifest: its name (output folder), scene folder and full set of options."""

    name: str
    scene: Path
    options: dict[str, Any] = field(default_factory=dict)


@dataclass
class Manifest:
    path: Path
    objects: list[BatchObject]


def _value(key: str, value: Any, where: str) -> Any:
    """``value`` checked against option ``key`` (text from a CSV cell is converted first)."""
    if key not in OPTIONS:
        raise DoodleError(f"{where}: unknown option {key!r} (options: {', '.join(OPTIONS)})")
    opt = OPTIONS[key]
    kind = opt.kind
    if isinstance(value, str) and kind in (int, float, bool, "count"):
        text = value.strip().lower()
        if kind is bool and text in ("true", "yes", "1", "false", "no", "0"):
            value = text in ("true", "yes", "1")
        elif kind in (int, "count") and re.fullmatch(r"[+-]?\d+", text):
            value = int(text)
        elif kind is float and re.fullmatch(r"[+-]?(\d+\.?\d*|\.\d+)(e[+-]?\d+)?", text):
            value = float(text)
        elif kind == "count" and text == "auto":
            value = "auto"
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if kind is bool:
        ok = isinstance(value, bool)
        expected = "true or false"
    elif kind is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
        expected = "a whole number"
    elif kind is float:
        ok = isinstance(value, float) and value == value
        expected = "a number"
    elif kind == "count":
        ok = value == "auto" or (isinstance(value, int) and not isinstance(value, bool) and value >= 0)
        expected = "auto or a whole number ≥ 0"
    elif kind is str:
        ok = isinstance(value, str) and value.strip() != ""
        expected = "a word"
    else:
        ok = value in kind
        expected = " or ".join(repr(k) for k in kind)
    if not ok:
        raise DoodleError(f"{where}: {key} must be {expected}, got {str(value)[:40]!r}")
    if opt.limits is not None and value != "auto" and not opt.limits[0] <= value <= opt.limits[1]:
        lo, hi = opt.limits
        raise DoodleError(f"{where}: {key} must be between {lo:g} and {hi:g}, got {value}")
    return value


def _entries(path: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The defaults and the raw object entries of a manifest file."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DoodleError(f"{path}: cannot read ({exc.strerror or exc})") from None
    suffix = path.suffix.lower()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise DoodleError(f"{path}: not UTF-8 text") from None
    if suffix == ".csv":
        rows = list(csv.DictReader(text.splitlines()))
        if rows and None in rows[0]:
            raise DoodleError(f"{path}: a row has more cells than the header")
        return {}, [{k.strip(): v for k, v in row.items() if k is not None and v is not None and v.strip() != ""}
                    for row in rows]
    try:
        if suffix == ".toml":
            doc = tomllib.loads(text)
        elif suffix == ".json":
            doc = json.loads(text)
        else:
            raise DoodleError(f"{path}: unknown manifest format {suffix or '(no suffix)'!r} (use .toml, .json or .csv)")
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise DoodleError(f"{path}: not valid {suffix[1:].upper()} ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict):
        raise DoodleError(f"{path}: expected a table with [defaults] and [[objects]]")
    unknown = set(doc) - {"defaults", "objects"}
    if unknown:
        raise DoodleError(f"{path}: unknown section {sorted(unknown)[0]!r} (expected defaults and objects)")
    defaults, objects = doc.get("defaults", {}), doc.get("objects", [])
    if not isinstance(defaults, dict):
        raise DoodleError(f"{path}: defaults must be a table of options")
    if not isinstance(objects, list) or not all(isinstance(o, dict) for o in objects):
        raise DoodleError(f"{path}: objects must be a list of tables ([[objects]] in TOML)")
    return defaults, objects


def load_manifest(path: str | Path) -> Manifest:
    """Read and check a manifest; scene paths are made absolute against the manifest's folder."""
    path = Path(path)
    defaults, entries = _entries(path)
    base = {key: _value(key, value, f"{path}: defaults") for key, value in defaults.items()}
    if not entries:
        raise DoodleError(f"{path}: no objects listed")
    objects: list[BatchObject] = []
    seen: dict[str, int] = {}
    for k, entry in enumerate(entries, start=1):
        where = f"{path}: object {k}"
        scene = entry.get("scene")
        if not isinstance(scene, str) or not scene.strip():
            raise DoodleError(f"{where}: needs a scene (a folder, relative to the manifest)")
        scene_path = (path.parent / scene.strip()).resolve()
        name = entry.get("name", scene_path.name)
        if not isinstance(name, str) or not _NAME.match(name):
            raise DoodleError(f"{where}: name {str(name)[:40]!r} must be letters, digits, '.', '_' or '-' "
                              "(it names the object's output folder)")
        if name in seen:
            raise DoodleError(f"{where}: name {name!r} is also object {seen[name]}'s (give each a distinct name)")
        seen[name] = k
        where = f"{path}: object {name!r}"
        options = {key: opt.default for key, opt in OPTIONS.items()}
        options.update(base)
        options.update({key: _value(key, value, where) for key, value in entry.items() if key not in ("scene", "name")})
        for key in ("masks", "style"):  # files named in the manifest are the manifest's, like the scenes
            value = options[key]
            is_file = (key == "masks" and value not in ("auto", "none")) or (key == "style" and value.endswith((".toml", ".json")))
            if is_file:
                options[key] = str((path.parent / value).resolve())
        objects.append(BatchObject(name, scene_path, options))
    return Manifest(path, objects)
