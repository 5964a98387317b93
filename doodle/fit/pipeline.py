"""``doodle fit``: posed images → stroke set. Stages (paper): superquadrics first, then curves with the
superquadrics frozen; checkpoints allow resuming, Ctrl-C keeps the best state."""

from __future__ import annotations


import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from scipy import ndimage

from .. import __version__
from ..arrays import spread_indices
from ..atomic import atomic_path
from ..cameras import Camera
from ..errors import DoodleError
from ..scenes import Scene
from ..strokes.model import OUTLINE_CELLS, CurveSet, DefaultCamera, SceneFrame, StrokeSet, SuperquadricSet, Voxels
from .config import AUTO_OUTLINE_CURVES, HULL_FALLBACK, FitConfig
from .init import farthest_points, initial_points
from .objectives import make_objective
from .optimize import StageState, run_stage
from .volume.outlines import (ABSTRACT_MIN_PRECISION, MIN_OUTLINE_PRECISION, abstraction_outlines, confirm_outlines,
                              outline_precision, raster_layer)
from .params import CurveParams, SuperquadricParams, initial_curves, initial_superquadrics
from .targets import build_targets, working_scene

CHECKPOINT_VERSION = 3
MAX_CHECKPOINT_BYTES = 1 << 30
#: Gain (share of line pixels) of the strong curves, whose outline coverage decides whether superquadrics
#: are fitted at all.
STRONG_GAIN = 0.002
FLAT_END = 0.3
"""ε₁ from which a superquadric is tried with flat ends (a cylinder's, a plate's) after it is grown."""
OUTLINE_VIEWS = 24  # training views on which a superquadric's outline must raise the sketch's F
#: Options that must match to resume a checkpoint.
RESUME_KEYS = ("curves", "superquadrics", "max_superquadrics", "size", "seed", "objective", "discover",
               "evidence_size", "evidence_voxels", "discovery_min_gain", "contours", "outline", "detail", "occluder")


@dataclass
class FitResult:
    strokes: StrokeSet
    interrupted: bool = False
    seconds: float = 0.0
    log: list[str] = field(default_factory=list)
    history: dict[str, list] = field(default_factory=dict)
    outline_drawn: float | None = None
    """Share of the training silhouettes' pixels that the superquadrics' outlines and the curves draw, the
    hull's outline not counted (after discovery; ``None`` without it). After ``outline="auto"`` fell back to
    the hull's outline: the compact abstraction's, which decided it."""


def _device(name: str) -> torch.device:
    if name.startswith("cuda") and not torch.cuda.is_available():
        raise DoodleError(f"--device {name}: CUDA is not available on this machine (use --device cpu)")
    try:
        return torch.device(name)
    except RuntimeError as exc:
        raise DoodleError(f"--device {name}: {exc}") from None


def _validate(cfg: FitConfig, scene: Scene) -> None:
    if cfg.curves != "auto" and (isinstance(cfg.curves, bool) or not isinstance(cfg.curves, int)
                                 or not 0 <= cfg.curves <= 4096):
        raise DoodleError(f"--curves must be 'auto' or in [0, 4096], got {cfg.curves!r}")
    if cfg.superquadrics != "auto" and not 0 <= int(cfg.superquadrics) <= 64:
        raise DoodleError(f"--superquadrics must be 'auto' or in [0, 64], got {cfg.superquadrics}")
    if cfg.curves == 0 and cfg.superquadrics == 0:
        raise DoodleError("nothing to fit: --curves 0 and --superquadrics 0")
    if cfg.curves == 0 and scene.masks is None:
        raise DoodleError(f"{scene.source}: --curves 0 leaves only superquadrics, which need masks, and the scene "
                          "has none (give --masks DIR or allow curves)")
    if (cfg.iterations is not None and cfg.iterations < 0) or cfg.sq_iterations < 0:
        raise DoodleError("--iterations must not be negative")
    if not 16 <= cfg.size <= 4096:
        raise DoodleError(f"--size must be in [16, 4096], got {cfg.size}")
    if not 64 <= cfg.evidence_size <= 4096:
        raise DoodleError(f"--evidence-size must be in [64, 4096], got {cfg.evidence_size}")
    if not 32 <= cfg.evidence_voxels <= 512:
        raise DoodleError(f"--evidence-voxels must be in [32, 512], got {cfg.evidence_voxels}")
    if cfg.views_per_step < 1:
        raise DoodleError(f"--views-per-step must be at least 1, got {cfg.views_per_step}")
    if len(scene) < 2:
        raise DoodleError(f"{scene.source}: need at least 2 views to fit, found {len(scene)}")
    if cfg.outline not in ("auto", "superquadrics", "hull"):
        raise DoodleError(f"--outline must be auto, superquadrics or hull, got {cfg.outline!r}")


def silhouette_pixels(sq: SuperquadricSet, frame: SceneFrame, cameras, grow_px: int = 3,
                      occluder: Voxels | None = None, hull: Voxels | None = None) -> list[np.ndarray]:
    """Per camera, the pixels within ``grow_px`` of the outline as the exporter draws it: the union's visible
    silhouette and the ``hull``'s."""
    from ..exporters.drawing import DrawOptions, draw_many

    strokes = StrokeSet(frame, CurveSet(), sq, occluder=occluder, hull=hull)
    drawings = draw_many(strokes, cameras, DrawOptions(curves=False, hidden="hide", silhouette_grid=(32, 64), tolerance=0.5))
    out = []
    for cam, per in zip(cameras, raster_layer(drawings, cameras, "silhouettes", lambda _: 0)):
        img = per.get(0, np.zeros((cam.height, cam.width), bool))
        out.append(ndimage.binary_dilation(img, iterations=grow_px) if grow_px else img)
    return out


def silhouette_scores(sq: SuperquadricSet, cameras, masks, size: int = 96, max_views: int = 12,
                      tau: float = 1.5) -> tuple[float, float]:
    """Mean mask IoU and boundary F-score (τ px) of the union's ray-cast silhouette against the masks.

    Cameras are scaled to ``size`` px; at most ``max_views`` views, evenly picked. The boundary score is the
    one that sees a missing neck between two balls, which barely changes the IoU.
    """
    from PIL import Image

    from ..exporters.visibility import union_mask

    step = max(1, len(cameras) // max_views)
    ious, fs = [], []
    for cam, mask in zip(cameras[::step], masks[::step]):
        c = cam.scaled(size / max(cam.width, cam.height))
        m = np.asarray(Image.fromarray(mask.astype(np.uint8) * 255).resize((c.width, c.height), Image.Resampling.BOX)) > 127
        u = union_mask(sq, c, samples=32) if len(sq) else np.zeros_like(m)
        union = (u | m).sum()
        ious.append((u & m).sum() / union if union else 1.0)
        bu, bm = u ^ ndimage.binary_erosion(u), m ^ ndimage.binary_erosion(m)
        if not bu.any() or not bm.any():
            fs.append(0.0)
            continue
        p = (ndimage.distance_transform_edt(~bm)[bu] <= tau).mean()
        r = (ndimage.distance_transform_edt(~bu)[bm] <= tau).mean()
        fs.append(2 * p * r / (p + r) if p + r else 0.0)
    return float(np.mean(ious)), float(np.mean(fs))


def silhouette_iou(sq: SuperquadricSet, cameras, masks) -> float:
    """Mean silhouette IoU of the union against the masks (see :func:`silhouette_scores`)."""
    return silhouette_scores(sq, cameras, masks)[0]


def prune_curves(curves: CurveSet, targets, max_distance_px: float, min_length_frac: float = 0.02
                 ) -> tuple[CurveSet, np.ndarray]:
    """Keep curves whose samples lie, in most views, within ``max_distance_px`` of a line and whose median
    projected length is at least ``min_length_frac`` of the image size. Returns the kept set and mask."""
    from .targets import lookup, project

    if len(curves) == 0:
        return curves, np.zeros(0, bool)
    c = torch.tensor(curves.control_points, dtype=torch.float32, device=targets.R.device)
    t = torch.linspace(0, 1, 24, device=c.device)[:, None]
    basis = torch.cat([(1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t**2 * (1 - t), t**3], -1)
    pts = torch.einsum("tk,nkd->ntd", basis, c)
    N, T, _ = pts.shape
    with torch.no_grad():
        uv, _ = project(pts.reshape(-1, 3), targets.R, targets.t, targets.K)  # (V, N·T, 2)
        dist = lookup(targets.line_dist, uv).reshape(-1, N, T).mean(-1)  # (V, N)
        length = (uv.reshape(-1, N, T, 2).diff(dim=2).norm(dim=-1).sum(-1))  # (V, N)
    med_dist = dist.median(dim=0).values.cpu().numpy()
    med_len = length.median(dim=0).values.cpu().numpy()
    keep = (med_dist <= max_distance_px) & (med_len >= min_length_frac * max(targets.width, targets.height))
    return CurveSet(curves.control_points[keep], curves.width_px), keep


def grow_superquadrics(interior: np.ndarray, work: Scene, frame: SceneFrame, cfg: FitConfig,
                       sq_stage: Callable[..., bool], rng: np.random.Generator,
                       device: torch.device, say: Callable[[str], None], min_gain: float = 0.01,
                       gen: torch.Generator | None = None) -> tuple[SuperquadricParams, bool]:
    """Fit as few superquadrics as the silhouettes need.

    Start with one; each round tries up to three moves — add one at the densest cluster of visual-hull voxels
    the union does not cover, split the largest one in two along its longest axis, or square the largest
    rounded one (ε₁ = ε₂ = :data:`FLAT_END`: a box) — fits briefly, and keeps the best if the silhouette score
    (mean of mask IoU and boundary F-score) improves by ``min_gain``.
    Then each one is tried once with flat ends (ε₁ = :data:`FLAT_END`), kept if the score improves by
    ``min_gain / 2``. A final joint refinement follows. (Fitting many at once and pruning leaves a ball split
    into overlapping pieces whose inner contours show in every view.) ``gen``, the stages' view sampler, is
    rewound after each box trial, so that a box that loses changes nothing else the growth draws.
    """
    from scipy.spatial import cKDTree

    from ..strokes.superquadric import quaternion_to_matrix, union_log_inside_outside

    def score(p: SuperquadricParams) -> float:
        return float(np.mean(silhouette_scores(p.to_set(), work.cameras, work.masks)))

    round_steps = max(20, cfg.sq_iterations // 5)
    center = interior.mean(axis=0)
    extent = np.clip(interior.std(axis=0) * 1.7, 0.05 * frame.radius, frame.radius)
    params = SuperquadricParams.from_set(SuperquadricSet(extent[None], np.array([[0.9, 0.9]]),
                                                         np.array([[1.0, 0, 0, 0]]), center[None])).to(device)
    if sq_stage(params, round_steps):
        return params, True
    best = score(params)
    while len(params) < cfg.sq_limit:
        current = params.to_set()
        candidates = []
        lf = union_log_inside_outside(interior, current.scale, current.shape, current.rotation, current.translation)
        uncovered = interior[lf > 0]
        if len(uncovered) >= 0.02 * len(interior):
            counts = cKDTree(uncovered).query_ball_point(uncovered, 0.15 * frame.radius, return_length=True)
            seed = uncovered[int(np.argmax(counts))]
            near = uncovered[np.linalg.norm(uncovered - seed, axis=1) < 0.3 * frame.radius]
            ext = np.clip(near.std(axis=0) * 1.7, 0.05 * frame.radius, 0.35 * frame.radius)
            candidates.append(("add", SuperquadricSet(
                np.vstack([current.scale, ext]), np.vstack([current.shape, [0.9, 0.9]]),
                np.vstack([current.rotation, [1.0, 0, 0, 0]]), np.vstack([current.translation, near.mean(0)]))))
        big = int(np.argmax(current.scale.max(axis=1)))
        axis = int(np.argmax(current.scale[big]))
        R = quaternion_to_matrix(current.rotation[big])
        offset = R[:, axis] * current.scale[big, axis] * 0.5
        half = current.scale[big].copy()
        half[axis] *= 0.5
        keep = [k for k in range(len(current)) if k != big]
        candidates.append(("split", SuperquadricSet(
            np.vstack([current.scale[keep], half, half]), np.vstack([current.shape[keep], current.shape[big], current.shape[big]]),
            np.vstack([current.rotation[keep], current.rotation[big], current.rotation[big]]),
            np.vstack([current.translation[keep], current.translation[big] + offset, current.translation[big] - offset]))))
        # Adam does not square a rounded cross-section either: a box fitted as rounded pills splits in two,
        # side by side, and their outlines meet in a notch. The largest rounded one is tried as a box.
        rounded = [k for k in range(len(current)) if current.shape[k].max() > FLAT_END]
        if rounded:
            boxy = max(rounded, key=lambda k: float(np.prod(current.scale[k])))
            shape = current.shape.copy()
            shape[boxy] = FLAT_END
            candidates.append(("box", replace(current, shape=shape)))
        results = []
        for move, cand in candidates:
            drawn_before = gen.get_state() if move == "box" and gen is not None else None
            trial = SuperquadricParams.from_set(cand).to(device)
            if sq_stage(trial, round_steps):
                return trial, True
            if drawn_before is not None:
                gen.set_state(drawn_before)
            results.append((score(trial), move, trial))
        top, move, trial = max(results, key=lambda r: r[0])
        if top - best < min_gain:
            break
        if move == "box":
            say(f"superquadrics: one is a box (score {best:.3f} → {top:.3f})")
        params, best = trial, top
    # Adam does not flatten a rounded end by itself (the mug's body: two stacked pills). Each one is tried
    # once with flat ends and kept so when the silhouettes agree better.
    for i in range(len(params)):
        current = params.to_set()
        if current.shape[i, 0] <= FLAT_END:
            continue
        shape = current.shape.copy()
        shape[i, 0] = FLAT_END
        trial = SuperquadricParams.from_set(replace(current, shape=shape)).to(device)
        if sq_stage(trial, round_steps):
            return trial, True
        if (top := score(trial)) >= best + min_gain / 2:
            say(f"superquadrics: one has flat ends (score {best:.3f} → {top:.3f})")
            params, best = trial, top
    say(f"superquadrics: {len(params)} explain the silhouettes (score {best:.3f}); refining")
    return params, sq_stage(params, max(20, cfg.sq_iterations // 2), "superquadrics (refine)")


def _save_checkpoint(path: Path, payload: dict) -> bool:
    """Write a checkpoint atomically; on failure (full disk, no permission) warn and carry on."""
    try:
        with atomic_path(path) as tmp:
            torch.save(payload, tmp)
        return True
    except (OSError, RuntimeError) as exc:  # torch reports a full disk as RuntimeError
        import warnings

        warnings.warn(f"{path}: checkpoint not written ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
                      "fitting goes on", RuntimeWarning, stacklevel=2)
        return False


def load_checkpoint(path: Path) -> dict:
    """Read a checkpoint: tensors and plain types only (``weights_only``), so a crafted file runs no code."""
    try:
        if path.stat().st_size > MAX_CHECKPOINT_BYTES:
            raise DoodleError(f"{path}: larger than {MAX_CHECKPOINT_BYTES} bytes; not a doodle checkpoint")
        ck = torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise DoodleError(f"{path}: no checkpoint to resume from") from None
    except DoodleError:
        raise
    except Exception as exc:  # torch raises many types for corrupt or foreign (pickled-object) files
        raise DoodleError(f"{path}: not a doodle checkpoint, or one that would run code when read "
                          f"({type(exc).__name__})") from None
    if not isinstance(ck, dict) or ck.get("format") != "doodle-checkpoint":
        raise DoodleError(f"{path}: not a doodle checkpoint")
    if ck.get("version") != CHECKPOINT_VERSION:
        raise DoodleError(f"{path}: checkpoint version {ck.get('version')!r}; this doodle resumes version "
                          f"{CHECKPOINT_VERSION} (start the fit again)")
    return ck


def _preview(strokes_fn: Callable[[], StrokeSet], cameras, out_dir: Path, tag: str) -> None:
    from PIL import Image
    import io

    from ..exporters import DrawOptions, contact_sheet, draw, svg_to_png, to_svg

    s = strokes_fn()
    if s.is_empty:
        return
    cams = cameras[:: max(1, len(cameras) // 6)][:6]
    ims = [Image.open(io.BytesIO(svg_to_png(to_svg(draw(s, c, DrawOptions(tolerance=0.5)), 0.5)))) for c in cams]
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_path(out_dir / f"{tag}.png") as tmp:
        contact_sheet(ims, cell=192).save(tmp, format="PNG")


def _superquadrics_from_checkpoint(tensors: list) -> SuperquadricSet:
    """The settled superquadrics of a checkpoint: shape parameters, then (since outline cells) the drawn flags
    and the outline cells, as float tensors."""
    a = [t.numpy().astype(np.float64) for t in tensors]
    sq = SuperquadricSet(*a[:4])
    if len(a) >= 6 and a[4].shape == (len(sq),) and a[5].shape == (len(sq), *OUTLINE_CELLS):
        cells = a[5] > 0.5
        sq = replace(sq, outline=a[4] > 0.5, outline_cells=None if cells.all() else cells)
    return sq


def _recheck_outlines(sq: SuperquadricSet, frame: SceneFrame,
                      judge: tuple[list[Camera], list[np.ndarray], list[np.ndarray]],
                      finish: Callable[[SuperquadricSet], SuperquadricSet], say: Callable[[str], None],
                      occluder: Voxels | None = None, min_precision: float = MIN_OUTLINE_PRECISION) -> SuperquadricSet:
    """Judge the drawn outlines again among the superquadrics that stay (``judge``: the cameras, line maps and
    masks of :func:`~doodle.fit.volume.outlines.keep_outlines`): once occluders that hid parts of an outline are
    dropped, more of it shows (on the Lego photos the cab's ellipsoid went from 75 % of its outline on the
    object's lines to 64 %). One that now strays draws no outline, and ``finish`` chooses the curves again."""
    precision = outline_precision(sq, frame, *judge, occluder=occluder)
    stray = sq.drawn & (precision < min_precision)
    if not stray.any():
        return sq
    for i in np.flatnonzero(stray):
        say(f"superquadrics: one draws no outline after all (only {precision[i]:.0%} of it lies on the object's "
            "lines once the other superquadrics are settled)")
    return finish(replace(sq, outline=sq.drawn & ~stray))


def fit(scene: Scene, config: FitConfig | None = None, checkpoint: str | os.PathLike | None = None,
        resume: bool = False, log: Callable[[str], None] = print, progress: bool = True) -> FitResult:
    """Fit a stroke set to a scene. See :class:`FitConfig` for the options.

    With masks (and ``discover``), curves are found from multi-view edge evidence (:mod:`.discover`), the
    superquadrics explain the silhouettes the curves do not draw, and a short stage refines the curves
    with the superquadrics frozen. Without masks, curves start at SfM points and are fitted from there.

    ``outline="auto"`` fits the compact abstraction first and, when its superquadrics and outline curves
    together draw less than :data:`~doodle.fit.config.HULL_FALLBACK` of the training silhouettes (an object
    they cannot abstract), fits again with the hull's outline and returns that.
    """
    cfg = config or FitConfig()
    _validate(cfg, scene)
    if cfg.outline != "auto":
        return _fit(scene, cfg, checkpoint, resume, log, progress)
    from ..strokes.binary import encode

    compact, whole = replace(cfg, outline="superquadrics"), replace(cfg, outline="hull")
    ck = load_checkpoint(Path(checkpoint)) if (resume and checkpoint) else None
    if ck is not None and ck["config"].get("outline") == "hull":  # interrupted in the fallback's fit
        return _fit(scene, whole, checkpoint, resume, log, progress)
    shared: dict = {}  # the discovery's traces, the same for both outlines: the fallback offers them again
    first = _fit(scene, compact, checkpoint, resume, log, progress, shared)
    falls_back = (not first.interrupted and first.outline_drawn is not None and cfg.superquadrics == "auto"
                  and first.outline_drawn < HULL_FALLBACK)
    if not falls_back:
        return first
    msg = (f"outline: superquadrics and curves draw {first.outline_drawn:.0%} of the silhouettes (under "
           f"{HULL_FALLBACK:.0%}): fitting again with the hull's outline (--outline superquadrics keeps the "
           f"{len(encode(first.strokes)):,} B abstraction)")
    log(msg)
    second = _fit(scene, whole, checkpoint, False, log, progress, shared)
    second.strokes.provenance["seconds"] = round(first.seconds + second.seconds, 2)  # the file's cost: both fits
    return replace(second, seconds=first.seconds + second.seconds, log=first.log + [msg] + second.log,
                   outline_drawn=first.outline_drawn)


def _fit(scene: Scene, cfg: FitConfig, checkpoint: str | os.PathLike | None, resume: bool,
         log: Callable[[str], None], progress: bool, shared: dict | None = None) -> FitResult:
    """One fit with a concrete outline (``"superquadrics"`` or ``"hull"``). ``shared`` carries the discovery's
    traces (:class:`~.discovery.discover.Traces`) from one fit of the scene with these evidence options to the
    next."""
    device = _device(cfg.device)
    clock_start = time.perf_counter()
    messages: list[str] = []

    def say(msg: str) -> None:
        messages.append(msg)
        log(msg)

    ckpt_path = Path(checkpoint) if checkpoint else None
    ck = load_checkpoint(ckpt_path) if (resume and ckpt_path) else None
    if ck is not None:
        for key in RESUME_KEYS:
            if ck["config"].get(key) != cfg.to_dict()[key]:
                raise DoodleError(f"{ckpt_path}: checkpoint was made with {key}={ck['config'].get(key)!r}, "
                                  f"not {cfg.to_dict()[key]!r}; use the same options to resume")
        say(f"resuming from {ckpt_path} ({ck['stage']} stage, step {ck['step']})")

    work = working_scene(scene, cfg.size)
    occluder = None
    if cfg.use_occluder and work.masks is not None:
        from .volume.hull import hull_occluder, occluder_voxels

        occluder = hull_occluder(work, occluder_voxels(cfg.size))
    rng = np.random.default_rng(cfg.seed)
    gen = torch.Generator(device=device)
    gen.manual_seed(cfg.seed)
    objective = make_objective(cfg.objective)
    frame = scene.frame
    discovering = cfg.discover and work.masks is not None and cfg.curves != 0
    normals: np.ndarray | None = None
    contour: np.ndarray | None = None
    candidates = strong = hull = None
    if discovering:
        if ck is not None and ck.get("discovered") is not None:
            start = np.asarray(ck["discovered"]["control_points"].numpy(), dtype=np.float64)
            normals = np.asarray(ck["discovered"]["normals"].numpy(), dtype=np.float64)
            contour = np.asarray(ck["discovered"]["contour"].numpy(), dtype=np.float64)
            outline = float(ck["discovered"]["outline"])
            seen = ck["discovered"].get("occluder")
            if occluder is not None and seen is not None and tuple(seen.shape) == occluder.occupied.shape:
                occluder = replace(occluder, occupied=seen.numpy().astype(bool))  # as cleared by the sight lines
            if ck["discovered"].get("hull") is not None:
                h = ck["discovered"]["hull"]
                hull = Voxels(h["origin"].numpy(), float(h["voxel"]), h["axes"].numpy(), h["occupied"].numpy().astype(bool))
        else:
            from .discovery.discover import choose_curves, find_candidates

            shared = {} if shared is None else shared
            candidates = find_candidates(working_scene(scene, cfg.evidence_size), cfg.evidence_voxels,
                                         contours=cfg.contours, texture=cfg.texture, hull_outline=cfg.outline_hull,
                                         log=say, traces=shared.get("traces"))
            shared["traces"] = candidates.traces
            if occluder is not None and candidates.evidence.free is not None:
                from .volume.hull import clear_seen

                occluder = clear_seen(occluder, candidates.evidence.grid, candidates.evidence.free)
            if cfg.outline_hull:
                from .volume.hull import outline_hull

                hull = outline_hull(candidates.evidence.grid, candidates.evidence.occupied)
            # the strong curves decide what superquadrics are needed for; the final choice comes after them
            strong = choose_curves(candidates, cfg.max_curves, max(STRONG_GAIN, cfg.min_gain), polish=False)
            start, normals, contour, outline = strong.control_points, strong.normals, strong.contour, strong.outline
        interior = surface = None
        method = "evidence"
    else:
        surface, interior, method = initial_points(work, cfg.init, rng, say)
        say(f"initialisation: {dict(points='SfM points', hull='visual hull', bbox='random in the bounding box')[method]}"
            f" ({len(surface)} candidate points)")
        n = max(cfg.max_curves, 1)
        start = initial_curves(farthest_points(surface, n, rng), 0.15 * frame.radius, rng)[: cfg.max_curves]
        if cfg.outline_hull and work.masks is not None:
            from .discovery.evidence import carve_hull
            from .volume.hull import outline_hull

            hull = outline_hull(*carve_hull(working_scene(scene, cfg.evidence_size), cfg.evidence_voxels))

    wants_sq = cfg.superquadrics != 0 and work.masks is not None
    # The compact abstraction: superquadrics fitted to the volume in 3D draw the outline (fit/volume/abstraction.py)
    abstracting = wants_sq and discovering and cfg.superquadrics == "auto" and not cfg.outline_hull
    if cfg.superquadrics != 0 and work.masks is None:
        say("superquadrics: the scene has no masks, fitting curves only")
    elif abstracting:
        pass
    elif cfg.superquadrics == "auto" and discovering:
        if outline >= cfg.outline_coverage:
            wants_sq = False
            say(f"superquadrics: none (the curves draw {outline:.0%} of the outlines)")
        else:
            say(f"superquadrics: fitting up to {cfg.sq_limit} (the curves draw {outline:.0%} of the outlines)")
    elif cfg.superquadrics == "auto" and ck is None:
        from .targets import straightness

        score = straightness(work)
        if score >= cfg.straight_threshold:
            wants_sq = False
            say(f"superquadrics: none ({score:.0%} of the image lines are long straight edges: curves draw them)")
        else:
            say(f"superquadrics: fitting up to {cfg.sq_limit} ({score:.0%} of the image lines are straight)")
    sq_scene = work
    if wants_sq and discovering and not abstracting:
        from .volume.hull import thick_volume

        volume = thick_volume(work, cfg.thin)
        interior, sq_scene = volume.interior, replace(work, masks=volume.masks)
        say(f"superquadrics: {volume.thin_share:.0%} of the mask pixels are thin parts, left to curves")
        if len(interior) < 10:
            wants_sq = False
            say("superquadrics: no thick part; curves only")

    # A fixed count starts from farthest points of the hull; "auto" grows its own set in the stage.
    fixed = wants_sq and cfg.superquadrics != "auto"
    sq_params = SuperquadricParams.from_set(initial_superquadrics(farthest_points(interior, int(cfg.superquadrics), rng), frame.radius)) \
        if fixed else None
    curve_params = CurveParams(start if len(start) else np.zeros((0, 4, 3)))
    curve_state = StageState()  # the superquadric stage restarts when resumed, so only this one is kept
    stage = "superquadrics" if wants_sq else "curves"
    final_sq: SuperquadricSet | None = None
    if ck is not None:
        stage = ck["stage"]
        if ck.get("final_superquadrics") is not None:
            final_sq = _superquadrics_from_checkpoint(ck["final_superquadrics"])
        if ck.get("sq_params") is not None and sq_params is not None:
            sq_params.load_state_dict(ck["sq_params"])
        if ck["curve_params"]["control"].shape == curve_params.control.shape:
            curve_params.load_state_dict(ck["curve_params"])
        if stage == "curves":
            curve_state = StageState.from_dict(ck["stage_state"])
        gen.set_state(ck["generator"])
    if sq_params is not None:
        sq_params.to(device)
    curve_params.to(device)

    def current_curves() -> CurveSet:
        return CurveSet(curve_params.to_set(cfg.width_px).control_points, cfg.width_px, normals, contour)

    def current_strokes() -> StrokeSet:
        sq = final_sq if final_sq is not None else (sq_params.to_set() if sq_params is not None else SuperquadricSet())
        return _stroke_set(frame, scene, current_curves() if stage == "curves" else CurveSet(), sq, cfg, method, 0.0,
                           occluder, hull)

    def checkpointer(stage_name: str):
        def save(state: StageState) -> None:
            if ckpt_path is None:
                return
            f32 = lambda a: torch.tensor(np.asarray(a), dtype=torch.float64)  # noqa: E731
            _save_checkpoint(ckpt_path, {
                "format": "doodle-checkpoint", "version": CHECKPOINT_VERSION, "config": cfg.to_dict(),
                "stage": stage_name, "step": state.step, "stage_state": state.to_dict(),
                "sq_params": sq_params.state_dict() if sq_params is not None else None,
                "curve_params": curve_params.state_dict(), "generator": gen.get_state(),
                "final_superquadrics": None if final_sq is None else
                [f32(final_sq.scale), f32(final_sq.shape), f32(final_sq.rotation), f32(final_sq.translation),
                 f32(final_sq.drawn), f32(final_sq.drawn_cells)],
                "discovered": None if not discovering else
                {"control_points": f32(start), "normals": f32(normals), "contour": f32(contour),
                 "outline": float(outline),
                 "occluder": None if occluder is None else torch.from_numpy(occluder.occupied.copy()),
                 "hull": None if hull is None else {
                     "origin": f32(hull.origin), "voxel": float(hull.voxel), "axes": f32(hull.axes),
                     "occupied": torch.from_numpy(hull.occupied.copy())}},
            })
        return save

    outline_drawn: float | None = None  # set by finish_discovery
    judge_views = spread_indices(len(work), OUTLINE_VIEWS)  # where superquadric outlines are judged
    judge_of = np.full(len(work) + 1, -1)  # a view's place among them, -1 if none (and for source -1)
    judge_of[judge_views] = np.arange(len(judge_views))

    def choose_beside(sq: SuperquadricSet, polish: bool, log: Callable[[str], None] = lambda m: None):
        """The choice of curves with ``sq``'s drawn outlines counted as drawn."""
        from .discovery.discover import choose_curves, outline_pixel_ids

        # An outline counts as drawn within 1.5 working pixels (the evidence views are finer). The hull's does
        # not: it gives way to the curves where they draw it, and a crisp edge along the outline draws it better.
        ratio = max(candidates.evidence.cameras[0].width / work.cameras[0].width, 1.0)
        taken = outline_pixel_ids(candidates, sq, frame, max(1, round(1.5 * ratio)), occluder) if sq.drawn.any() else None
        return choose_curves(candidates, cfg.max_curves, cfg.min_gain, taken, polish=polish,
                             outline_curves=cfg.outline_curves, whole_outline=cfg.whole_outline,
                             most_outline=AUTO_OUTLINE_CURVES, log=log)

    def curves_beside(sq: SuperquadricSet) -> tuple[CurveSet, np.ndarray]:
        """The curves chosen beside ``sq``'s outlines, and per curve the judge view it was traced in (or -1)."""
        found = choose_beside(sq, polish=False)
        return CurveSet(found.control_points, cfg.width_px, found.normals, found.contour), judge_of[found.source]

    def finish_discovery(sq: SuperquadricSet) -> SuperquadricSet:
        """The final choice of curves, with the kept superquadrics' outlines counted as drawn."""
        nonlocal start, normals, contour, curve_params, outline_drawn

        found = choose_beside(sq, polish=True, log=say)
        start, normals, contour = found.control_points, found.normals, found.contour
        outline_drawn = found.outline_drawn
        curve_params = CurveParams(start if len(start) else np.zeros((0, 4, 3))).to(device)
        if len(sq) and not sq.drawn.all() and occluder is not None:
            say(f"superquadrics: {int((~sq.drawn).sum())} that only hide what is behind them dropped (the hull "
                "occluder does that)")
            return sq.subset(sq.drawn)
        if len(sq) and not sq.drawn.all():
            from .volume.outlines import useful_occluders

            ev = candidates.evidence
            kept = useful_occluders(sq, CurveSet(start, cfg.width_px, normals, contour), frame,
                                    [ev.cameras[v] for v in candidates.views],
                                    [ev.depth[v] for v in candidates.views], ev.margin)
            if len(kept) < len(sq):
                say(f"superquadrics: {len(sq) - len(kept)} occluder(s) would hide more visible lines than hidden ones; dropped")
            return kept
        return sq

    if discovering and candidates is not None and not wants_sq:
        finish_discovery(SuperquadricSet())
    if ck is None and discovering and stage == "curves":
        checkpointer(stage)(StageState())  # discovery is not repeated on resume

    def previewer(tag: str):
        if cfg.preview_dir is None:
            return None
        return lambda step: _preview(current_strokes, work.cameras, Path(cfg.preview_dir), f"{tag}_{step:05d}")

    interrupted = False
    if stage == "superquadrics":
        targets = None if abstracting else build_targets(sq_scene, str(device))

        def sq_stage(params: SuperquadricParams, steps: int, label: str = "superquadrics") -> bool:
            objective.begin(targets, frame, gen)
            _, stopped = run_stage(label, params, lambda v: objective.superquadric_terms(params, v), steps,
                                   cfg.lr_superquadrics, targets.views, min(4, targets.views), gen, None, None,
                                   cfg.checkpoint_every, previewer("superquadrics"), cfg.preview_every, progress)
            return stopped

        if abstracting:
            from .volume.abstraction import abstract_volume

            if candidates is not None:
                grid, occupied = candidates.evidence.grid, candidates.evidence.occupied
            else:  # resumed: discovery is not repeated, the hull is carved again
                from .discovery.evidence import carve_hull

                grid, occupied = carve_hull(working_scene(scene, cfg.evidence_size), cfg.evidence_voxels)
            final_sq = abstract_volume(grid.origin, grid.voxel, grid.axes, occupied, cfg.thin, cfg.sq_limit,
                                       cfg.level.superquadric_gain, seed=cfg.seed, log=say).superquadrics
            sq_params = SuperquadricParams.from_set(final_sq)
        elif cfg.superquadrics == "auto":
            sq_params, interrupted = grow_superquadrics(interior, sq_scene, frame, cfg, sq_stage, rng, device, say,
                                                         gen=gen)
        else:
            interrupted = sq_stage(sq_params, cfg.sq_iterations)
        final_sq = sq_params.to_set()
        judge = None  # the views, lines and masks on which outlines are judged
        if discovering and cfg.superquadrics == "auto" and not interrupted:
            from .discovery.evidence import object_lines
            from .volume.outlines import keep_outlines

            judge = ([work.cameras[v] for v in judge_views],
                     [object_lines(work.images[v], work.masks[v]) for v in judge_views],
                     [work.masks[v] for v in judge_views])
            if abstracting:
                # The abstraction draws the outline, measured against the crisp feature curves discovery found
                # first (creases, not traces across smooth faces)
                crisp = (contour == 0) if contour is not None else np.ones(len(start), bool)
                if candidates is not None and crisp.any():
                    from .discovery.texture import on_smooth_faces

                    crisp[crisp] = ~on_smooth_faces(start[crisp], candidates.evidence.grid,
                                                    candidates.evidence.occupied)
                final_sq = abstraction_outlines(final_sq, CurveSet(start[crisp], cfg.width_px), frame, *judge,
                                                occluder=occluder, log=say)
            else:
                final_sq = keep_outlines(final_sq, CurveSet(start, cfg.width_px, normals, contour), frame, *judge,
                                         curves_beside=curves_beside if candidates is not None else None,
                                         occluder=occluder, hull=hull, log=say)
        if discovering and candidates is not None and not interrupted:
            final_sq = finish_discovery(final_sq)
            if judge is not None and final_sq.drawn.any():
                final_sq = _recheck_outlines(final_sq, frame, judge, finish_discovery, say, occluder,
                                             ABSTRACT_MIN_PRECISION if abstracting else MIN_OUTLINE_PRECISION)
        if judge is not None and final_sq.drawn.any():
            from .discovery.evidence import object_lines

            # Last, with the curves chosen: curves picked to fill an outline's gaps came out as ticks (the
            # snowman's nose: 3 curves → 7, held-out F no better). Every view votes (1.4 s for 100 at 256 px).
            lines = [object_lines(image, mask) for image, mask in zip(work.images, work.masks)]
            final_sq = confirm_outlines(final_sq, frame, work.cameras, lines, work.masks, occluder)
            cells = final_sq.outline_cells
            if cells is not None:
                say(f"superquadrics: outlines drawn where the views confirm them ({int((~cells).sum())} of "
                    f"{cells[final_sq.drawn].size} surface cells left out)")
        say(f"superquadrics: {len(final_sq)}, {int(final_sq.drawn.sum())} drawn (training silhouette IoU "
            f"{silhouette_iou(final_sq, sq_scene.cameras, sq_scene.masks):.3f})")
        stage = "curves"
        checkpointer("curves")(StageState())
    if final_sq is None:
        final_sq = SuperquadricSet()

    steps = cfg.curve_iterations
    if not interrupted and len(curve_params) and steps > 0:
        exclude = silhouette_pixels(final_sq, frame, work.cameras, occluder=occluder, hull=hull) \
            if len(final_sq) or hull is not None else None
        targets = build_targets(work, str(device), exclude)
        objective.begin(targets, frame, gen)
        lr = cfg.lr_curves * frame.radius * (0.25 if discovering else 1.0)  # discovered curves only need polish
        _, interrupted = run_stage(
            "curves", curve_params, lambda v: objective.curve_terms(curve_params, v), steps, lr,
            targets.views, min(cfg.views_per_step, targets.views), gen, curve_state, checkpointer("curves"),
            cfg.checkpoint_every, previewer("curves"), cfg.preview_every, progress)
    if interrupted:
        say("interrupted: keeping the best state so far")
        if ckpt_path is not None:
            checkpointer(stage)(curve_state if stage == "curves" else StageState())
    curves = current_curves() if stage == "curves" else CurveSet(width_px=cfg.width_px)
    if cfg.prune_curves and len(curves) and stage == "curves" and steps > 0 and not discovering:
        n_before = len(curves)
        curves, _ = prune_curves(curves, targets, cfg.curve_max_distance_px)
        say(f"curves: kept {len(curves)} of {n_before} (the others do not lie on lines across the views)")
    if discovering and len(curves) and work.masks is not None:
        curves = _confirm_hiding(curves, final_sq, frame, work, say, occluder, hull)
    seconds = time.perf_counter() - clock_start
    strokes = _stroke_set(frame, scene, curves, final_sq, cfg, method, seconds, occluder, hull)
    if ckpt_path is not None and not interrupted:
        ckpt_path.unlink(missing_ok=True)
    return FitResult(strokes, interrupted, seconds, messages, outline_drawn=outline_drawn)


def _confirm_hiding(curves: CurveSet, sq: SuperquadricSet, frame: SceneFrame, work: Scene,
                    say: Callable[[str], None], occluder: Voxels | None = None, hull: Voxels | None = None
                    ) -> CurveSet:
    """The curves with facing kept only where the training views do not contradict it (:mod:`.hiding`)."""
    from .discovery.evidence import object_lines
    from .hiding import wrongly_hidden

    views = spread_indices(len(work), OUTLINE_VIEWS)
    # without thin parts' axes: a thin part's hidden edge lies beside its axis, as near as its visible one
    wrong = wrongly_hidden(curves, sq, frame, [work.cameras[v] for v in views],
                           [object_lines(work.images[v], work.masks[v], thin=0) for v in views], occluder=occluder,
                           hull=hull)
    if not wrong.any():
        return curves
    say(f"curves: {int(wrong.sum())} drawn from every side (the views see what their faces would hide)")
    normals = curves.normals.copy()
    normals[wrong] = 0.0
    return replace(curves, normals=normals)


def _stroke_set(frame: SceneFrame, scene: Scene, curves: CurveSet, sq: SuperquadricSet, cfg: FitConfig,
                method: str, seconds: float, occluder: Voxels | None = None, hull: Voxels | None = None) -> StrokeSet:
    return StrokeSet(
        frame=SceneFrame(frame.up.copy(), frame.center.copy(), frame.radius, DefaultCamera(**vars(frame.camera))),
        curves=curves, superquadrics=sq, occluder=occluder, hull=hull,
        provenance={"tool": f"doodle {__version__}", "source": scene.source, "objective": cfg.objective,
                    "iterations": cfg.curve_iterations, "superquadric_iterations": cfg.sq_iterations,
                    "init": method, "seed": cfg.seed, "seconds": round(seconds, 2)},
    )


