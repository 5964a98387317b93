"""The fit's options: one dataclass, :class:`FitConfig`, whose fields are declared in groups with their help
text, range and command-line spelling. ``doodle fit``'s options, the batch manifest's fit keys and the checks
of :meth:`FitConfig.check` are all derived from these declarations (:func:`config_fields`), so an option is
added in one place.

Groups, in the order ``doodle fit --help`` shows them:

- ``discovery``    how curves are found from the images' multi-view edge evidence
- ``abstraction``  how much the sketch holds: the detail level, curves and superquadrics
- ``outline``      what draws the view-dependent outline
- ``optimiser``    the gradient stages (``--no-discover``, ``--outline hull``'s superquadrics, fixed counts)
- ``run``          resolution, seed, device, checkpoints and previews
"""

from __future__ import annotations

from dataclasses import Field, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any, Literal, Union

from ..errors import DoodleError

#: With ``curves="auto"`` and ``detail="high"``, discovery chooses at most this many by all the lines they
#: draw...
AUTO_MAX_CURVES = 128
#: ...and, when those are not enough, up to this many more for the outline alone (see
#: :func:`doodle.fit.discovery.discover.choose_curves`): an object with more lines than the sketch holds is still drawn whole.
AUTO_OUTLINE_CURVES = 128

#: See :attr:`FitConfig.whole_outline`.
WHOLE_OUTLINE = 0.8
#: ``outline="auto"`` draws the hull's outline when the compact abstraction (superquadrics and the detail
#: level's outline curves, past its budget if need be) draws less than this share of the training
#: silhouettes: an object no few superquadrics abstract (see :attr:`FitConfig.outline`).
HULL_FALLBACK = 0.7

InitMethod = Literal["auto", "points", "hull", "bbox"]
Outline = Literal["auto", "superquadrics", "hull"]
Detail = Literal["low", "medium", "high"]

GROUPS = ("discovery", "abstraction", "outline", "optimiser", "run")
"""The option groups, in the order ``doodle fit --help`` lists them."""


@dataclass(frozen=True)
class DetailLevel:
    """What one abstraction level allows: the most curves discovery chooses, the most superquadrics, the least
    share of the volume's surface a superquadric must add, and the least share of the line pixels the next
    curve must newly explain. Every level draws the whole object: the superquadrics close the outline of its
    thick parts, and curves draw its thin parts and sharp edges before any detail."""

    curves: int
    outline_curves: int
    """...and at most this many more for outline the superquadrics leave open (a closed outline at every level)."""
    superquadrics: int
    superquadric_gain: float
    curve_gain: float
    features: int = 0
    """At most this many features on smooth faces (eyes, a muzzle, buttons, patches), chosen by salience
    (:mod:`doodle.fit.discovery.salience`)..."""
    open_features: bool = False
    """...closed ones only (rings: an eye, a button, a patch), or open marks as well after every ring (a mouse's
    button seams: at ``medium`` its painted boundaries drawn went 0.692 → 0.859 with them, F 0.987 → 0.975)."""
    outline_always: bool = False
    """The outline curves are chosen whether or not the ``curves`` budget is spent (``high``: its 128 are rarely
    spent, and without this the chair's and ABC-NEF's ``high`` drew fewer curves than ``medium``, 50 against 58
    and 48 against 54); otherwise only when it is (an object with more lines than the budget holds)."""
    min_salience: float = 0.01
    """...down to this salience (:data:`~doodle.fit.discovery.salience.MIN_SALIENCE` at ``low``): ``medium`` and
    ``high`` draw the secondary lines too — a seam across the object, which its length ranks low (DTU skull's
    cranial cut: 0.0095)."""


DETAIL_LEVELS: dict[str, DetailLevel] = {
    "low": DetailLevel(curves=12, outline_curves=24, superquadrics=6, superquadric_gain=0.02, curve_gain=0.004,
                       features=3),
    "medium": DetailLevel(curves=40, outline_curves=24, superquadrics=8, superquadric_gain=0.01, curve_gain=0.0015,
                          features=8, open_features=True, min_salience=0.005),
    "high": DetailLevel(curves=AUTO_MAX_CURVES, outline_curves=AUTO_OUTLINE_CURVES, superquadrics=12,
                        superquadric_gain=0.005, curve_gain=0.0005, features=24, open_features=True,
                        min_salience=0.002, outline_always=True),
}
"""``--detail``: at ``medium`` (the default) a stroke file of an object like a teapot or a cow takes under 2 kB."""


def option(group: str, default: Any, help: str, *, kind: Any, limits: tuple[float, float] | None = None,
           flag: str | None = None, internal: str | None = None, manifest: bool = True) -> Any:
    """Declare one :class:`FitConfig` field.

    Args:
        group: one of :data:`GROUPS`.
        help: the option's help text (``doodle fit --help``, the manifest's option list).
        kind: ``int``, ``float``, ``bool``, ``str``, ``"count"`` (a number or ``auto``), ``"path"``, or a tuple of
            the allowed words.
        limits: inclusive bounds of a number.
        flag: the command-line name (default ``--field-name``).
        internal: not on the command line nor in manifests, and why (a test checks every field is one or the
            other).
        manifest: whether ``doodle batch`` manifests may set it (run options such as the device do not apply).
    """
    assert group in GROUPS, group
    meta = {"group": group, "help": help, "kind": kind, "limits": limits, "flag": flag, "internal": internal,
            "manifest": manifest and internal is None}
    return field(default=default, metadata=meta)


@dataclass
class FitConfig:
    """Every option of a fit (``doodle fit``'s, one for one; see the module doc for the groups). The defaults
    are what ``doodle fit SCENE -o OUT`` does."""

    # -- discovery -----------------------------------------------------------------------------------------
    curves: Union[int, Literal["auto"]] = option(
        "discovery", "auto", "Bézier curves: 'auto' (discovery chooses how many, up to the --detail level's) or a "
        "maximum; 0 draws the outline with superquadrics (or the hull) alone.", kind="count", limits=(0, 4096))
    discover: bool = option(
        "discovery", True, "Find curves from multi-view edge evidence (needs masks); --no-discover fits curves "
        "started at SfM or hull points with the distance-field objective (the gradient stage).", kind=bool)
    contours: bool = option(
        "discovery", True, "Also offer the training views' outlines traced into 3D: view-independent curves where "
        "they run along a crease and, beside superquadrics, contour curves drawn where a view grazes them.",
        kind=bool)
    texture: bool = option(
        "discovery", True, "Take strokes that lie on smooth faces of the hull (print, decals, grain) only for the "
        "outline they draw: printed lines are not structure.", kind=bool)
    evidence_size: int = option(
        "discovery", 512, "Image size (larger side, px) of the 3D edge evidence and of the carved volume; never "
        "enlarged.", kind=int, limits=(64, 4096))
    evidence_voxels: int = option(
        "discovery", 192, "Voxels of the carved volume along the object's longest side.", kind=int,
        limits=(32, 512))
    discovery_min_gain: float | None = option(
        "discovery", None, "Discovery adds curves while the next one newly explains at least this share of the "
        "line pixels over the views [default: the --detail level's].", kind=float, limits=(0.0, 1.0),
        flag="--min-gain")

    # -- abstraction ---------------------------------------------------------------------------------------
    detail: Detail = option(
        "abstraction", "medium", "Abstraction level: how many curves + superquadrics at most, beside curves for the "
        "outline the superquadrics leave open ("
        + ", ".join(f"{k} {v.curves} + {v.superquadrics}" for k, v in DETAIL_LEVELS.items())
        + "); every level draws the whole object.", kind=tuple(DETAIL_LEVELS))
    superquadrics: Union[int, Literal["auto"]] = option(
        "abstraction", "auto", "Superquadrics: 'auto' (fitted to the carved volume, as many as explain it, up to "
        "the --detail level's) or a number fitted to the silhouettes.", kind="count", limits=(0, 64))
    max_superquadrics: int | None = option(
        "abstraction", None, "At most this many superquadrics with --superquadrics auto [default: the --detail "
        "level's].", kind=int, limits=(0, 64))
    max_features: int | None = option(
        "abstraction", None, "At most this many features inside the outline (eyes, a muzzle, buttons, patches: lines "
        "on smooth faces), chosen by salience, not length [default: the --detail level's].", kind=int,
        limits=(0, 256), flag="--features")
    max_bytes: int = option(
        "abstraction", 2500, "The compact file's size at most (bytes): past it, the curves whose ink on the views' "
        "lines no other stroke draws is least are left out until it fits; 0: no limit. The hull's outline "
        "(--outline hull, or auto's fallback) is not cut.", kind=int, limits=(0, 100_000_000), flag="--max-bytes")
    thin: float = option(
        "abstraction", 0.06, "Parts thinner than this share of the object's size (legs, cables, handles) are "
        "drawn by curves, never by superquadrics.", kind=float, limits=(0.0, 0.5))
    deform: bool = option(
        "abstraction", True, "Let the fitted superquadrics taper and bend (Barr's deformations) where a plain one "
        "explains its part poorly and the views say the deformed one draws it better (a spout, a horn); "
        "--no-deform keeps them plain (for tools that read plain superquadrics only).", kind=bool)
    outline_coverage: float = option(
        "abstraction", 0.9, "Beside the hull's outline, --superquadrics auto fits none when the discovered curves "
        "already draw this share of the silhouettes' outline pixels.", kind=float, limits=(0.0, 1.0))
    straight_threshold: float = option(
        "abstraction", 0.6, "Without discovery, --superquadrics auto fits none when this share of the image lines "
        "are long straight edges (a boxy object, which curves draw exactly).", kind=float, limits=(0.0, 1.0))

    # -- outline -------------------------------------------------------------------------------------------
    outline: Outline = option(
        "outline", "auto", "What draws the outline: superquadrics fitted to the object's volume (compact, ~2 kB), "
        "its voxel hull stored in the file (most faithful, 4-30 kB), or auto: superquadrics, and the hull when "
        f"they and the outline curves draw under {HULL_FALLBACK:.0%} of the silhouettes (an intricate object).",
        kind=("auto", "superquadrics", "hull"))
    occluder: bool | None = option(
        "outline", None, "Store a coarse voxel hull that hides what lies behind the object's bulk [default: with "
        "--outline hull].", kind=bool)

    # -- optimiser (the gradient stages) -------------------------------------------------------------------
    iterations: int | None = option(
        "optimiser", None, "Steps of the distance-field curve stage [default: 0 after discovery, else 1500].",
        kind=int, limits=(0, 1_000_000))
    sq_iterations: int = option(
        "optimiser", 400, "Steps of the silhouette superquadric stage (--outline hull's growth, a fixed "
        "--superquadrics count).", kind=int, limits=(0, 1_000_000))
    abstraction_steps: int = option(
        "optimiser", 100, "Adam steps of each superquadric fit of the volume's abstraction (--superquadrics auto): "
        "each part's, then the union's.", kind=int, limits=(1, 100_000))
    views_per_step: int = option(
        "optimiser", 8, "Training views per step of the distance-field curve stage.", kind=int, limits=(1, 10_000))
    lr_curves: float = option(
        "optimiser", 0.01, "Adam learning rate of the curves' control points, in units of the scene radius.",
        kind=float, limits=(1e-6, 10.0))
    lr_superquadrics: float = option(
        "optimiser", 0.02, "Adam learning rate of the superquadric parameters.", kind=float, limits=(1e-6, 10.0))
    objective: str = option(
        "optimiser", "edges", "Objective of the gradient stages (edges: the weight-free default).", kind=str)
    init: InitMethod = option(
        "optimiser", "auto", "Where --no-discover places its first curves: SfM points, the carved hull, random in "
        "the bounding box, or auto (points, else hull, else bbox).", kind=("auto", "points", "hull", "bbox"))
    prune_curves: bool = option(
        "optimiser", True, "After the distance-field stage, drop curves that do not lie on lines across the views "
        "or are shorter than 2% of the image.", kind=bool, flag="--prune")
    curve_max_distance_px: float = option(
        "optimiser", 2.5, "--prune keeps a curve whose median distance to the views' lines is at most this (px).",
        kind=float, limits=(0.0, 100.0), flag="--prune-distance")

    # -- run -----------------------------------------------------------------------------------------------
    size: int = option(
        "run", 256, "Working resolution (larger image side, px) of the superquadric judging and the gradient "
        "stages.", kind=int, limits=(16, 4096), flag="--size")
    seed: int = option("run", 0, "Random seed (a fit is deterministic for one seed and thread count).", kind=int,
                       limits=(0, 2**31 - 1))
    device: str = option("run", "cpu", "torch device of the gradient stages: cpu, cuda, cuda:1 ...", kind=str,
                         manifest=False)
    width_px: float = option("run", 1.5, "Stroke width recorded in the file (px at the recorded image size).",
                             kind=float, limits=(0.05, 100.0), flag="--width")
    checkpoint_every: int = option(
        "run", 200, "Steps between checkpoints inside a gradient stage (one is also written after every stage).",
        kind=int, limits=(1, 1_000_000), manifest=False)
    preview_every: int = option("run", 250, "Steps between --preview sheets.", kind=int, limits=(1, 1_000_000),
                                manifest=False)
    preview_dir: Path | None = option(
        "run", None, "Write contact sheets of the strokes here every --preview-every steps of a gradient stage.",
        kind="path", flag="--preview", manifest=False)

    # -- derived ---------------------------------------------------------------------------------------------
    @property
    def level(self) -> DetailLevel:
        return DETAIL_LEVELS[self.detail]

    @property
    def outline_hull(self) -> bool:
        """Whether the fit stores the hull whose outline every view draws (``outline="hull"``)."""
        return self.outline == "hull"

    @property
    def use_occluder(self) -> bool:
        return self.outline_hull if self.occluder is None else bool(self.occluder)

    @property
    def load_size(self) -> int:
        """The image size (larger side, px) a scene is loaded at for this fit: the finer of the evidence and
        working sizes (``doodle fit`` and ``doodle batch`` alike)."""
        return max(self.size, self.evidence_size)

    @property
    def max_curves(self) -> int:
        if self.curves != "auto":
            return int(self.curves)
        return AUTO_MAX_CURVES if self.outline_hull else self.level.curves

    @property
    def sq_limit(self) -> int:
        """The most superquadrics ``superquadrics="auto"`` fits."""
        return self.level.superquadrics if self.max_superquadrics is None else int(self.max_superquadrics)

    @property
    def features(self) -> int:
        """Features on smooth faces chosen by salience beside the structural curves: none for a fixed number of
        curves or without the texture judgement (nothing is marked as lying on a smooth face)."""
        if self.curves != "auto" or not self.texture:
            return 0
        return self.level.features if self.max_features is None else int(self.max_features)

    @property
    def min_gain(self) -> float:
        """Discovery's least gain per curve (``discovery_min_gain``, else the detail level's; with the hull's
        outline, the finest)."""
        if self.discovery_min_gain is not None:
            return float(self.discovery_min_gain)
        return DETAIL_LEVELS["high"].curve_gain if self.outline_hull else self.level.curve_gain

    @property
    def outline_curves(self) -> int:
        """Curves discovery may add for the outline alone once ``max_curves`` are chosen: none for a number,
        none when the hull's outline is drawn (it completes the outline); beside superquadrics, the detail
        level's (an outline the superquadrics leave open is closed by curves at every level: the lamp's cone,
        which no superquadric draws, at ``low`` held-out recall 0.604 with none, 0.803 with 24). At ``medium``
        64 curves in all keep a file under 2 kB (the rocker arm: 91 curves and 2.6 kB with 80 more allowed,
        F 0.915; 52 and 1.7 kB with 20, F 0.904)."""
        return 0 if self.curves != "auto" or self.outline_hull else self.level.outline_curves

    @property
    def whole_outline(self) -> float:
        """Beside superquadrics, outline curves go on past the level's budget while the outline drawn is under
        this share of the outline pixels (``doodle.fit.discovery.discover.choose_curves``): an intricate object
        no superquadric abstracts (Lego: held-out recall 0.646 at ``medium`` without) is drawn whole in a larger
        file, while a teapot or a cow, whose superquadrics close the outline, keeps its 1 kB."""
        return 0.0 if self.curves != "auto" or self.outline_hull else WHOLE_OUTLINE

    @property
    def curve_iterations(self) -> int:
        if self.iterations is not None:
            return self.iterations
        return 0 if self.discover else 1500

    def check(self) -> None:
        """Raise :class:`~doodle.errors.DoodleError` naming the option (as ``doodle fit`` spells it) for a value
        of the wrong kind or out of its range."""
        for f in config_fields():
            value = getattr(self, f.name)
            if value is None and f.default is None:
                continue
            problem = _problem(f.metadata["kind"], f.metadata["limits"], value)
            if problem:
                raise DoodleError(f"{cli_flag(f)} {problem}, got {value!r}")
        if self.curves == 0 and self.superquadrics == 0:
            raise DoodleError("nothing to fit: --curves 0 and --superquadrics 0")

    def to_dict(self) -> dict:
        d = asdict(self)
        d["preview_dir"] = str(self.preview_dir) if self.preview_dir else None
        return d


def config_fields(group: str | None = None) -> list[Field]:
    """The declared fields of :class:`FitConfig` (of one group), in declaration order."""
    return [f for f in fields(FitConfig) if group is None or f.metadata["group"] == group]


def cli_flag(f: Field) -> str:
    """The command-line spelling of a field (``--evidence-size``)."""
    return f.metadata["flag"] or "--" + f.name.replace("_", "-")


def manifest_key(f: Field) -> str:
    """A field's key in a batch manifest: its ``doodle fit`` flag with underscores (``evidence_size``,
    ``min_gain``), but ``fit_size`` for ``--size`` (the manifest's ``size`` is the exported views')."""
    return "fit_size" if f.name == "size" else cli_flag(f)[2:].replace("-", "_")


def _problem(kind: Any, limits: tuple[float, float] | None, value: Any) -> str | None:
    """What is wrong with ``value`` for an option of ``kind`` and ``limits`` (``None``: nothing)."""
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == "count":
        if value == "auto":
            return None
        if not (isinstance(value, int) and not isinstance(value, bool)):
            return "must be 'auto' or a whole number"
    elif kind is int:
        if not (isinstance(value, int) and not isinstance(value, bool)):
            return "must be a whole number"
    elif kind is float:
        if not number or value != value:
            return "must be a number"
    elif kind is bool:
        return None if isinstance(value, bool) else "must be true or false"
    elif kind is str:
        return None if isinstance(value, str) and value.strip() else "must be a word"
    elif kind == "path":
        return None if isinstance(value, (str, Path)) else "must be a path"
    elif isinstance(kind, tuple):
        return None if value in kind else "must be " + " or ".join(kind)
    if limits is not None and not limits[0] <= value <= limits[1]:
        lo, hi = limits
        return f"must be in [{lo:g}, {hi:g}]"
    return None
