"""Plain photos: structure-from-motion with pycolmap (SIFT, exhaustive matching, incremental mapping set for
photos walked round one object), then the COLMAP parser. The model is cached in
``PHOTOS/.doodle-sfm`` and reused; ``PHOTOS/.doodle-sfm/registration.txt`` lists the photos left out, and why.

Phone photos often store portrait shots as landscape pixels plus an EXIF orientation tag, which COLMAP
ignores. When any photo has such a tag, upright copies are written to ``PHOTOS/.doodle-sfm/images`` and
posed instead, so that cameras, images and sketches are all upright.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from typing import Callable

import numpy as np
from PIL import ImageOps

from ..errors import SceneError
from .colmap import load_colmap, quiet_pycolmap
from .images import open_image, save_turned
from .scene import Scene
from .sensor import one_lens, sensor_copies, write_upright_model

ORIENTATION = 0x0112  # the EXIF orientation tag
FEATURE_SIZE = 1600
"""px: SIFT features are found on photos brought to this long side at most (a phone's 4000 px photo holds no
more features that match across views, and takes 6× the time)."""
EXHAUSTIVE_PHOTOS = 300
"""Up to this many photos every pair is matched; beyond, each photo with its neighbours in name order (the order
a capture is taken in), as COLMAP's sequential matching does."""
ONE_LENS = "one-lens.txt"
"""Beside the SfM cache of portrait and landscape photos: they were posed as one lens (an earlier release's
cache, without it, gave each orientation or photo its own camera)."""
REPORT = "registration.txt"
"""Beside the SfM cache: every photo, registered or left out, and why."""
IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp", ".webp"}


def _to_stderr(message: str) -> None:
    """Default progress log: stderr, so that a command printing results on stdout (``eval --json -``) stays
    parseable."""
    print(message, file=sys.stderr)


def photo_files(root: Path) -> list[Path]:
    return sorted(p for p in root.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)


def misaimed(centres: np.ndarray, directions: np.ndarray, min_angle: float = 0.08, factor: float = 4.0,
             max_share: float = 1 / 3) -> np.ndarray:
    """Cameras that do not look at the object the others look at, ``(N,)`` bool.

    Photos of one object are aimed at it, so the optical axes (``centres`` ``(N, 3)``, unit ``directions``
    ``(N, 3)``) nearly meet at a common focus: the point nearest all axes in the least-squares sense, found
    again without the outliers. A camera whose axis misses that focus by more than ``factor`` times the median
    angle (and ``min_angle`` radians) is flagged. On repetitive or symmetric objects SfM can register a few
    photos on the wrong side of the object; their axes then miss the focus (Lego: 7 of 53 wrong views at
    0.11–0.15 rad, every right one at most 0.03). Nothing is flagged when the axes do not meet (a
    forward-facing capture), or when more than ``max_share`` would be.
    """
    n = len(centres)
    if n < 4:
        return np.zeros(n, bool)
    keep = np.ones(n, bool)
    for _ in range(2):
        proj = np.eye(3)[None] - directions[keep, :, None] * directions[keep, None, :]  # (K, 3, 3)
        A, b = proj.sum(axis=0), np.einsum("kij,kj->i", proj, centres[keep])
        if np.linalg.cond(A) > 1e6:
            return np.zeros(n, bool)
        focus = np.linalg.solve(A, b)
        to_focus = focus - centres
        dist = np.linalg.norm(to_focus, axis=1)
        cos = np.einsum("ij,ij->i", to_focus, directions) / np.maximum(dist, 1e-12)
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        keep = angle <= max(min_angle, factor * float(np.median(angle)))
    if (~keep).sum() > max_share * n:
        return np.zeros(n, bool)
    return ~keep


def without_spurious_distortion(rec, log: Callable[[str], None] = lambda m: None):
    """The reconstruction refitted with its lens distortion fixed at zero, when the distortion does not earn
    its parameters; else ``rec`` itself.

    COLMAP's default camera for photos fits a radial distortion whatever the lens. When the features sit near
    the image centre (an object in the middle of the frame) the distortion trades off against the focal
    length and is poorly fixed: on the Lego photos (renders, no distortion) it fitted k = −0.021, which made
    images and poses disagree by about a pixel and weakened the 3D edge votes (silhouette recall against the
    true masks 0.743 → 0.764 without it; reprojection error 0.514 px with it, 0.506 px without). The test is
    the Bayesian information criterion: the distortion stays when it lowers the squared reprojection error,
    summed over the observations, by more than ln(observations) noise variances per parameter. A real lens's
    distortion does so by far; Akaike's looser two variances kept a spurious one in one fit out of six.
    """
    import pycolmap

    cams = [c for c in rec.cameras.values() if len(c.extra_params_idxs())
            and np.any(np.asarray(c.params)[c.extra_params_idxs()] != 0)]
    observations = rec.compute_num_observations()
    rec.update_point_3d_errors()  # the stored errors may predate SfM's last adjustment
    before = rec.compute_mean_reprojection_error()
    if not cams or observations == 0 or not before > 0:
        return rec
    trial = pycolmap.Reconstruction(rec)
    for cam in trial.cameras.values():
        params = np.array(cam.params)
        params[cam.extra_params_idxs()] = 0.0
        cam.params = params
    options = pycolmap.BundleAdjustmentOptions()
    options.refine_extra_params = False
    options.print_summary = False  # Ceres prints its summary whatever COLMAP's log level
    try:
        with quiet_pycolmap():
            pycolmap.bundle_adjustment(trial, options)
    except Exception:  # pycolmap's errors vary; the refit is only an improvement, so SfM's own model stays
        return rec
    after = trial.compute_mean_reprojection_error()
    n_params = sum(len(c.extra_params_idxs()) for c in cams)
    # squared errors ≈ observations × mean², in units of the noise variance (≈ the fuller model's mean²)
    if not np.isfinite(after) or observations * (after**2 - before**2) / before**2 > np.log(observations) * n_params:
        return rec
    log(f"structure-from-motion: no lens distortion (reprojection error {after:.3f} px without it, "
        f"{before:.3f} px with it)")
    return trial


def drop_misaimed(rec, log: Callable[[str], None]) -> list[str]:
    """Deregister the photos of ``rec`` (a ``pycolmap.Reconstruction``) that :func:`misaimed` flags; returns
    their names."""
    ids = sorted(rec.reg_image_ids())
    centres = np.array([rec.image(i).projection_center() for i in ids]).reshape(-1, 3)
    directions = np.array([rec.image(i).viewing_direction() for i in ids]).reshape(-1, 3)
    bad = [i for i, flag in zip(ids, misaimed(centres, directions)) if flag]
    if not bad:
        return []
    for i in bad:
        rec.deregister_frame(rec.image(i).frame_id)
    names = sorted(rec.image(i).name for i in bad)
    log(f"structure-from-motion: dropped {len(bad)} photos whose cameras do not aim at the object, so their "
        f"poses are likely wrong: {', '.join(names[:8])}{' …' if len(names) > 8 else ''}")
    return names


def run_sfm(root: str | Path, log: Callable[[str], None] = _to_stderr) -> Path:
    """Pose the photos in ``root``; returns the folder holding the COLMAP model (``cameras.bin`` …).

    Raises:
        SceneError: when fewer than 3 photos are given or no reconstruction registers at least 3 of them.
    """
    import pycolmap

    root = Path(root)
    photos = photo_files(root)
    if len(photos) < 3:
        raise SceneError(f"{root}: structure-from-motion needs at least 3 photos, found {len(photos)}")
    work = root / ".doodle-sfm"
    model = work / "model"
    if (model / "cameras.bin").exists():
        log(f"structure-from-motion: reusing {model}")
        if not (work / ONE_LENS).exists() and one_lens(_upright_sizes(photos)[0]):
            log(f"structure-from-motion: that model, made by an earlier release, gives portrait and landscape "
                f"photos cameras of their own; delete {work} to pose them as one lens (better poses)")
        return model
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    db = work / "database.db"
    # Photos of one size are taken to come from one camera: one shared set of intrinsics is far better
    # constrained (on 34 Lego photos, camera centres 1 % off instead of 3–6 % with a camera per photo).
    # Portrait and landscape photos of one size are one lens too: posed turned the way the sensor lies, through
    # one camera, and turned back upright after (sensor.py).
    sizes, rotated = _upright_sizes(photos)
    image_dir = root
    if rotated:
        image_dir = work / "images"
        image_dir.mkdir()
        log(f"structure-from-motion: {len(rotated)} photos carry an EXIF rotation; posing upright copies")
        for p in photos:
            if p in rotated:
                with open_image(p) as im:
                    save_turned(ImageOps.exif_transpose(im), im, image_dir / p.name)
            else:
                shutil.copyfile(p, image_dir / p.name)
    turned = {p.name for p, (w, h) in zip(photos, sizes) if h > w} if one_lens(sizes) else set()
    posed_dir = sensor_copies(image_dir, [p.name for p in photos], turned, work / "sensor") if turned else image_dir
    shared = len(set(sizes)) == 1
    exhaustive = len(photos) <= EXHAUSTIVE_PHOTOS
    log(f"structure-from-motion (pycolmap): {len(photos)} photos, "
        f"{'one shared camera' if shared else 'one lens for portrait and landscape' if turned else 'a camera per photo size'}"
        f"; extracting SIFT features (long side {FEATURE_SIZE} px at most) and matching "
        f"{'every pair' if exhaustive else 'neighbours in name order'}")
    try:
        with quiet_pycolmap():
            # (for the mixed orientations of one lens, a camera per photo is no fallback where one camera fails:
            # on a small capture it registered 13-16 of 24 photos as nonsense, focal lengths up to 6.6 million px)
            recs = _pose(db, posed_dir, photos, shared or bool(turned), exhaustive, work / "sparse")
    except Exception as exc:  # pycolmap reports failures as RuntimeError/ValueError with long texts
        raise SceneError(f"{root}: structure-from-motion failed ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    finally:  # the turned copies are only for SfM; the scene loads the upright photos
        shutil.rmtree(work / "sensor", ignore_errors=True)
    best = _main_model(list(recs.values()))
    if best is None or best.num_reg_images() < 3:
        n = 0 if best is None else best.num_reg_images()
        write_registration(work, db, photos, None, list(recs.values()), [])
        raise SceneError(f"{root}: structure-from-motion failed: registered {n} of {len(photos)} photos "
                         f"(photos need overlap and texture; or give poses as a COLMAP model); see "
                         f"{work / REPORT}")
    dropped = drop_misaimed(best, log)
    best = without_spurious_distortion(best, log)
    model.mkdir(parents=True, exist_ok=True)
    if turned:  # the model of the upright photos, which the scene loads and masks are drawn on
        write_upright_model(best, turned, work / "upright")
        best = pycolmap.Reconstruction(str(work / "upright"))
        shutil.rmtree(work / "upright")
        (work / ONE_LENS).write_text("portrait photos posed turned, through the landscape photos' camera\n")
    best.write(str(model))
    left = write_registration(work, db, photos, best, list(recs.values()), dropped)
    log(f"structure-from-motion: registered {best.num_reg_images()} of {len(photos)} photos, "
        f"{best.num_points3D()} points" + (f"; the {left} left out and why: {work / REPORT}" if left else ""))
    return model


def _upright_sizes(photos: list[Path]) -> tuple[list[tuple[int, int]], list[Path]]:
    """Each photo's size ``(w, h)`` as it is shown (EXIF orientation applied), and the photos that carry an
    EXIF rotation."""
    sizes, rotated = [], []
    for p in photos:
        try:
            with open_image(p) as im:
                if im.getexif().get(ORIENTATION, 1) not in (0, 1):
                    rotated.append(p)
                    sizes.append(ImageOps.exif_transpose(im).size)
                else:
                    sizes.append(im.size)
        except (OSError, SyntaxError):
            raise SceneError(f"{p}: not a readable image") from None
    return sizes, rotated


def _pose(db: Path, image_dir: Path, photos: list[Path], one_camera: bool, exhaustive: bool, out: Path) -> dict:
    """SIFT features, matches and incremental mapping of ``photos`` (in ``image_dir``) into the database ``db``
    and the models under ``out``: one camera for all photos, or one per image size (COLMAP's ``AUTO``)."""
    import pycolmap

    extraction = pycolmap.FeatureExtractionOptions()
    extraction.max_image_size = FEATURE_SIZE
    mode = pycolmap.CameraMode.SINGLE if one_camera else pycolmap.CameraMode.AUTO
    pycolmap.extract_features(db, image_dir, image_names=[p.name for p in photos], camera_mode=mode,
                              extraction_options=extraction)
    # (guided matching found more matches on a carpet capture, registered 40 of 40 instead of 39, and took six
    # times as long: not used)
    matching = pycolmap.FeatureMatchingOptions()
    if exhaustive:
        pycolmap.match_exhaustive(db, matching_options=matching)
    else:  # a capture walked round the object, in order: neighbours and, quadratically, farther ones
        pairing = pycolmap.SequentialPairingOptions()
        pairing.overlap, pairing.quadratic_overlap = 20, True
        pycolmap.match_sequential(db, matching_options=matching, pairing_options=pairing)
    out.mkdir(parents=True, exist_ok=True)
    return pycolmap.incremental_mapping(db, image_dir, out, options=mapper_options())


def mapper_options():
    """Incremental mapping suited to photos walked round one object: pairs start and photos join on fewer
    matches and narrower angles than COLMAP's defaults (which suit scenes walked through), and a photo is tried
    more often before it is given up."""
    import pycolmap

    options = pycolmap.IncrementalPipelineOptions()
    options.mapper.init_min_num_inliers = 50
    options.mapper.init_min_tri_angle = 8.0
    options.mapper.abs_pose_min_num_inliers = 15
    options.mapper.abs_pose_min_inlier_ratio = 0.15
    options.mapper.max_reg_trials = 5
    options.extract_colors = False
    return options


def _main_model(recs: list):
    """The model of the object: the one registering the most photos (a split capture's larger part)."""
    return max(recs, key=lambda r: (r.num_reg_images(), r.num_points3D()), default=None)


def write_registration(work: Path, db: Path, photos: list[Path], best, recs: list, dropped: list[str]) -> int:
    """Write :data:`REPORT` beside the SfM cache: every photo, registered or left out, and why; returns the
    number left out. The reasons, from the feature database and the models: too few features, too few matches
    with any other photo, posed in a separate model, dropped as aimed elsewhere, or not placed by the mapper."""
    import sqlite3

    with sqlite3.connect(db) as con:
        ids = {name: image_id for image_id, name in con.execute("SELECT image_id, name FROM images")}
        keypoints = dict(con.execute("SELECT image_id, rows FROM keypoints"))
        best_pair: dict[int, int] = {}
        for pair_id, rows in con.execute("SELECT pair_id, rows FROM two_view_geometries"):
            a, b = divmod(int(pair_id), 2147483647)
            for i in (a, b):
                best_pair[i] = max(best_pair.get(i, 0), int(rows or 0))
    registered = {best.image(i).name for i in best.reg_image_ids()} if best is not None else set()
    elsewhere = {best_i.name: len(r.reg_image_ids()) for r in recs if r is not best
                 for best_i in (r.image(i) for i in r.reg_image_ids())}
    lines, left = [], 0
    for p in photos:
        image_id = ids.get(p.name)
        kp, matches = keypoints.get(image_id, 0), best_pair.get(image_id, 0)
        if p.name in registered:
            why = "registered"
        else:
            left += 1
            if p.name in dropped:
                why = "left out: its camera does not aim at the object the others aim at (a likely wrong pose)"
            elif kp < 100:
                why = f"left out: too few features ({kp}; a blurred, dark or plain photo)"
            elif matches < 15:
                why = f"left out: too few matches with any other photo (at most {matches}; too little overlap)"
            elif p.name in elsewhere:
                why = f"left out: posed in a separate model of {elsewhere[p.name]} photos that does not join the main one"
            else:
                why = f"left out: the mapper could not place it ({kp} features, up to {matches} matches)"
        lines.append(f"{p.name}\t{why}")
    from ..atomic import write_text

    write_text(work / REPORT, f"# {len(photos) - left} of {len(photos)} photos registered\n" + "\n".join(lines) + "\n")
    return left


def load_photos(root: str | Path, downscale: float = 1.0, log: Callable[[str], None] = _to_stderr,
                size: int | None = None) -> Scene:
    """Run (or reuse) SfM on a folder of photos and load the result; ``root/masks`` is used when present."""
    root = Path(root)
    model = run_sfm(root, log)
    upright = root / ".doodle-sfm" / "images"
    scene = load_colmap(model, images_dir=upright if upright.is_dir() else root,
                        masks_dir=root / "masks" if (root / "masks").is_dir() else None, downscale=downscale, size=size)
    return scene
