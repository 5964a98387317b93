"""Fitting configuration: one dataclass, mapped 1:1 onto ``doodle fit`` options."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Literal, Union

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


DETAIL_LEVELS: dict[str, DetailLevel] = {
    "low": DetailLevel(curves=12, outline_curves=24, superquadrics=6, superquadric_gain=0.02, curve_gain=0.004),
    "medium": DetailLevel(curves=40, outline_curves=24, superquadrics=8, superquadric_gain=0.01, curve_gain=0.0015),
    "high": DetailLevel(curves=AUTO_MAX_CURVES, outline_curves=AUTO_OUTLINE_CURVES, superquadrics=12,
                        superquadric_gain=0.005, curve_gain=0.0005),
}
"""``--detail``: at ``medium`` (the default) a stroke file of an object like a teapot or a cow takes under 2 kB."""



@dataclass
class FitConfig:
    curves: Union[int, Literal["auto"]] = "auto"
    """Cubic Bézier curves (view-independent strokes): ``"auto"`` lets stroke discovery choose how many (at
    most ``AUTO_MAX_CURVES``, and ``AUTO_OUTLINE_CURVES`` more for the outline when those fall short); a
    number is an upper bound."""
    discover: bool = True
    """Find the curves from multi-view edge evidence (needs masks) and refine them; ``False``: fit curves
    started at random hull points with the distance-field objective alone (the earlier method)."""
    evidence_size: int = 512
    """Image size (larger side, px) for the edge evidence; never enlarged."""
    evidence_voxels: int = 192
    """Evidence grid voxels along the object's longest side."""
    contours: bool = True
    """Discovery also offers each training view's outline traced into 3D (``doodle.fit.discovery.rims``): with
    ``outline_hull`` as view-independent curves only (where the outline runs along a crease, the trace is the
    crease); without it also as contour curves, drawn only from the views that graze them, which outline
    smooth parts no fixed curve or superquadric draws."""
    texture: bool = True
    """Discovery takes strokes lying on smooth faces of the visual hull only for the outline they draw: a line
    printed on a face (a decal, a label, grain) is texture, not structure (``doodle.fit.discovery.texture``)."""
    outline: Outline = "auto"
    """What draws the view-dependent outline. ``"auto"``: the compact abstraction, and the hull's outline
    (a second fit) when superquadrics and outline curves together draw less than :data:`HULL_FALLBACK` of the
    training silhouettes — an intricate object that a few superquadrics cannot abstract (Lego: 56 %, drawn as
    a plate and ticks; the procedural and Blender scenes: 88–99 %). ``"superquadrics"`` (the compact abstraction): superquadrics
    fitted to the visual hull in 3D (:mod:`doodle.fit.volume.abstraction`), curves where they do not reach; they also
    hide what lies behind them. ``"hull"`` (the most faithful outline, 4–30 kB): the visual hull carved for
    the evidence (``evidence_voxels`` on its longest side) is stored in the stroke file and every view draws
    the outline of its projection where the other strokes leave it undrawn (``doodle.exporters.outline``);
    strokes on smooth faces, chosen only for the outline they draw, are then not chosen. Masks only."""
    detail: Detail = "medium"
    """Abstraction level (:data:`DETAIL_LEVELS`): how many curves and superquadrics at most, and how much each
    must add. ``curves``, ``max_superquadrics`` and ``discovery_min_gain``, when given, override it."""
    occluder: bool | None = None
    """Store the visual hull, on a coarse grid, in the stroke file as an occluder that hides the curves and
    outlines behind it (with masks only; occluder-only superquadrics are then not kept). ``None``: with the
    hull's outline only (the superquadrics hide what is behind them, and the file stays small)."""
    discovery_min_gain: float | None = None
    """Discovery keeps adding strokes while the next one newly explains at least this share of all line
    pixels over the views (``None``: the detail level's)."""
    outline_coverage: float = 0.9
    """``superquadrics="auto"`` fits none when the discovered curves already draw this share of the
    silhouettes' outline pixels; otherwise it fits them and keeps those whose outline is right and new."""
    thin: float = 0.06
    """Parts thinner than this share of the object's size are drawn by curves, never by superquadrics."""
    superquadrics: Union[int, Literal["auto"]] = "auto"
    """Number of superquadrics, or ``"auto"``: none when the images' lines are mostly long straight edges
    (straightness ≥ ``straight_threshold``: boxy objects, which curves draw exactly); otherwise fit up to
    ``max_superquadrics``, drop those that add less than 2 % silhouette IoU, refit the rest, and drop all if together they
    cannot explain the silhouette."""
    straight_threshold: float = 0.6
    max_superquadrics: int | None = None
    """At most this many superquadrics with ``superquadrics="auto"`` (``None``: the detail level's)."""
    iterations: int | None = None
    """Adam steps of the distance-field curve stage: default 0 after discovery (discovered curves are
    already polished on the 3D evidence, which is sharper than the working images), 1500 without it."""
    sq_iterations: int = 400
    """Adam steps of the superquadric stage (before the curve stage, as in the paper)."""
    size: int = 256
    """Working resolution: images are resized so their larger side has this many pixels."""
    views_per_step: int = 8
    seed: int = 0
    device: str = "cpu"
    objective: str = "edges"
    """Name of a registered objective (see :mod:`doodle.fit.objectives`)."""
    init: InitMethod = "auto"
    """Where initial strokes are placed: SfM ``points``, a visual ``hull`` carved from the masks, random in the
    bounding box (``bbox``), or ``auto`` (points, else hull, else bbox)."""
    prune_curves: bool = True
    """After fitting, drop curves that do not lie on lines across the views (median distance above
    ``curve_max_distance_px``) or are shorter than 2 % of the image; ``curves`` is then a maximum."""
    curve_max_distance_px: float = 2.5
    lr_curves: float = 0.01
    """Adam learning rate of the curve control points, in units of the scene radius."""
    lr_superquadrics: float = 0.02
    width_px: float = 1.5
    checkpoint_every: int = 200
    preview_every: int = 250
    preview_dir: Path | None = None

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
    def max_curves(self) -> int:
        if self.curves != "auto":
            return int(self.curves)
        return AUTO_MAX_CURVES if self.outline_hull else self.level.curves

    @property
    def sq_limit(self) -> int:
        """The most superquadrics ``superquadrics="auto"`` fits."""
        return self.level.superquadrics if self.max_superquadrics is None else int(self.max_superquadrics)

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

    def to_dict(self) -> dict:
        d = asdict(self)
        d["preview_dir"] = str(self.preview_dir) if self.preview_dir else None
        return d
