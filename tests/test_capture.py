"""Real captures: photos of mixed orientation (some EXIF-rotated), lens distortion, no masks, a textured
floor and background: the generated phone capture of the chair, end to end."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image
from scipy import ndimage

from doodle.cli import cli
from doodle.errors import SceneError
from doodle.samples.capture import write_capture
from doodle.samples.raycast import render_rgba
from doodle.samples.scenes import SCENES
from doodle.scenes import load_colmap, load_scene


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


@pytest.fixture(scope="module")
def capture(tmp_path_factory) -> Path:
    return write_capture("chair", tmp_path_factory.mktemp("capture") / "chair", n=15, size=160)


def test_capture_mixes_orientations_and_exif(capture):
    sizes = {Image.open(p).size for p in (capture / "images").glob("*.jpg")}
    assert sizes == {(160, 120), (120, 160)}
    tags = [Image.open(p).getexif().get(0x0112) for p in sorted((capture / "images").glob("*.jpg"))]
    assert 6 in tags
    assert "SIMPLE_RADIAL" in (capture / "sparse/0/cameras.txt").read_text()


def test_images_and_cameras_agree_after_undistortion(capture):
    """Every loaded view, portrait or landscape, EXIF-tagged or not, undistorted: the true mask lands where
    the pinhole camera sees the object."""
    scene = load_colmap(capture, masks_dir=capture / "true_masks")
    prims = SCENES["chair"]()
    assert {(c.width, c.height) for c in scene.cameras} == {(160, 120), (120, 160)}
    ious = [_iou(render_rgba(prims, c)[..., 3] > 127, m) for c, m in zip(scene.cameras, scene.masks)]
    assert min(ious) > 0.85 and np.mean(ious) > 0.92, ious


def test_undistort_moves_a_point_to_its_pinhole_projection():
    import pycolmap

    from doodle.scenes.colmap import undistort

    cam = pycolmap.Camera.create_from_model_name(1, "OPENCV", 100.0, 120, 90)
    cam.params = [100.0, 104.0, 61.0, 44.0, -0.2, 0.05, 0.001, -0.002]
    p = np.array([[0.45, 0.3, 1.0]])  # near the corner, where distortion is large
    ud, vd = cam.img_from_cam(p)[0]
    img = np.full((90, 120, 3), 255, np.uint8)
    yy, xx = np.mgrid[0:90, 0:120] + 0.5
    img[(xx - ud) ** 2 + (yy - vd) ** 2 < 4] = 0
    out, _ = undistort(img, None, cam, (120, 90))
    dark = out[..., 0] < 128
    v, u = np.nonzero(dark)
    assert abs(u.mean() + 0.5 - (100.0 * 0.45 + 61.0)) < 0.5
    assert abs(v.mean() + 0.5 - (104.0 * 0.3 + 44.0)) < 0.5
    assert abs(ud - (100.0 * 0.45 + 61.0)) > 2  # the distortion was real (2.6 px here)


def test_automatic_masks_match_the_truth_and_ignore_the_floor(capture, tmp_path):
    from doodle.scenes.automask import with_masks

    truth = load_colmap(capture, masks_dir=capture / "true_masks").masks
    scene = load_colmap(capture)
    assert scene.masks is None
    found = with_masks(scene, "auto", tmp_path / "m", log=lambda m: None).masks
    ious = [_iou(a, b) for a, b in zip(found, truth)]
    assert np.mean(ious) > 0.85, ious
    assert len(list((tmp_path / "m").glob("*.png"))) == len(scene)
    # a mask folder round-trips through --masks DIR, still known as automatic (its marker file) …
    again = with_masks(scene, tmp_path / "m", log=lambda m: None)
    assert all(_iou(a, b) > 0.99 for a, b in zip(again.masks, found))
    assert again.masks_automatic and again.subset([0, 1]).masks_automatic
    # … until the marker is deleted (masks fixed by hand are exact); given masks never are
    (tmp_path / "m" / "doodle-masks.json").unlink()
    assert not with_masks(scene, tmp_path / "m", log=lambda m: None).masks_automatic
    assert not load_colmap(capture, masks_dir=capture / "true_masks").masks_automatic
    assert with_masks(scene, "none", log=lambda m: None).masks is None


def test_automatic_masks_open_the_gaps_the_hull_fills(capture, monkeypatch):
    """Photo-consistency opens what the first cuts and the hull carved from them fill (under the seat, between
    the legs): the masks spill onto the truth's background less than without that step, and what they gain there
    outweighs the little object they lose (a few grazing faces whose colour changes with the view)."""
    from doodle.scenes import automask

    truth = load_colmap(capture, masks_dir=capture / "true_masks").masks
    scene = load_colmap(capture)
    opened = automask.auto_masks(scene, log=lambda m: None)
    monkeypatch.setattr(automask, "_holes", lambda error, hull, uv: np.zeros_like(hull))
    filled = automask.auto_masks(scene, log=lambda m: None)
    spill = lambda masks: sum(int((m & ~t).sum()) for m, t in zip(masks, truth))
    lost = lambda masks: sum(int((t & ~m).sum()) for m, t in zip(masks, truth))
    assert spill(opened) < 0.85 * spill(filled), (spill(opened), spill(filled))
    assert spill(filled) - spill(opened) > lost(opened) - lost(filled), (spill(opened), spill(filled), lost(opened), lost(filled))
    assert np.mean([_iou(m, t) for m, t in zip(opened, truth)]) >= np.mean([_iou(m, t) for m, t in zip(filled, truth)])


def test_holes_are_inconsistent_blobs_where_no_object_point_lands():
    from doodle.scenes.automask import HOLE_MIN_ERROR, _holes

    hull = np.zeros((80, 80), bool)
    hull[10:70, 10:70] = True
    error = np.where(hull, 2.0, 0.0)
    error[20:32, 20:32] = 40.0  # a hole: inconsistent, no point lands in it
    error[45:57, 45:57] = 40.0  # inconsistent too, but object points land in it (a shiny patch)
    error[60:62, 20:22] = 40.0  # a speck
    error[20:32, 45:57] = HOLE_MIN_ERROR - 1  # a low-contrast patch, consistent enough
    yy, xx = np.mgrid[10:70:3, 10:70:3]
    points = np.c_[xx.ravel(), yy.ravel()].astype(float) + 0.5
    points = points[~((points[:, 0] >= 20) & (points[:, 0] < 32) & (points[:, 1] >= 20) & (points[:, 1] < 32))]
    holes = _holes(error, hull, points)
    assert holes[24:28, 24:28].all()
    assert not holes[45:57, 45:57].any() and not holes[58:64, 18:24].any() and not holes[20:32, 45:57].any()
    assert not holes[~hull].any()
    # without enough points to know the object's own colour error, nothing is opened
    assert not _holes(error, hull, points[:5]).any()


def test_a_photo_consistent_strip_the_background_colour_stays_object():
    """A strip of the object coloured like the background (Lego's grey lower edge of its plate): GrabCut's
    colour models cut it off; the photos agreeing on its colour at a depth in the hull keep it."""
    from doodle.scenes.automask import _final_cut, _surely_object

    rng = np.random.default_rng(0)
    H = W = 96
    grey = np.array([110, 110, 110])
    image = np.clip(grey + rng.normal(0, 40, (H, W, 3)), 0, 255)  # a busy backdrop around grey
    image[20:60, 20:76] = [230, 190, 40]  # the object's body …
    image[60:66, 20:76] = grey + rng.normal(0, 4, (6, 56, 3))  # … and its strip, the backdrop's mean colour
    image = image.astype(np.uint8)
    truth = np.zeros((H, W), bool)
    truth[20:66, 20:76] = True
    hull = ndimage.binary_dilation(truth, iterations=2)  # the hull's projection: a little fat
    yy, xx = np.mgrid[22:58:3, 22:74:3]
    points = np.c_[xx.ravel(), yy.ravel()].astype(float) + 0.5  # SfM points on the body only
    error = np.where(hull, 30.0, 0.0)  # the backdrop seen through the fat hull: inconsistent
    error[truth] = 3.0  # the surface: the neighbouring photos agree
    core_error = error.copy()
    core_error[62:66] = np.inf  # the strip's lower half lies outside the hull itself (only in the wider band) …
    no_holes = np.zeros_like(hull)
    plain = _final_cut(image, hull, points, no_holes)
    sure = _surely_object(error, error, hull, points, no_holes)
    kept = _final_cut(image, hull, points, no_holes, sure)
    assert plain[61:65, 24:72].mean() < 0.5  # GrabCut alone drops the strip
    # kept, at the cost of some backdrop of its colour that the object's colour model now takes: a better mask
    assert kept[60:66, 22:74].all() and _iou(kept, truth) > _iou(plain, truth) + 0.03
    assert sure[truth].all() and not sure[hull & ~truth].any()
    # … which is then not sure (only the hull's own depths count), nor are holes, nor is anything without points
    assert not _surely_object(error, core_error, hull, points, no_holes)[62:66].any()
    holes = np.zeros_like(hull)
    holes[30:40, 30:40] = True
    assert not _surely_object(error, error, hull, points, holes)[holes].any()
    assert not _surely_object(error, error, hull, points[:5], no_holes).any()


def test_support_plane_is_removed():
    from doodle.cameras import Camera, look_at
    from doodle.scenes.automask import remove_support_plane

    rng = np.random.default_rng(0)
    floor = np.c_[rng.uniform(-2, 2, (400, 2)), np.full(400, -1.0)]
    obj = rng.normal(0, 0.3, (200, 3))
    cams = []
    for a in np.linspace(0, 2 * np.pi, 8, endpoint=False):
        R, t = look_at(np.array([3 * np.cos(a), 3 * np.sin(a), 1.5]), np.zeros(3), np.array([0, 0, 1.0]))
        cams.append(Camera(100, 100, 50, 50, 100, 100, R, t))
    kept, removed = remove_support_plane(np.r_[floor, obj], cams, radius=1.0)
    assert removed
    assert (kept[:, 2] > -0.97).all() and len(kept) > 180
    # A base plate twice as wide as the object on it, framed by every photo (Lego's): part of the object.
    plate = np.c_[rng.uniform(-0.6, 0.6, (400, 2)), np.full(400, -1.0)]
    kept, removed = remove_support_plane(np.r_[plate, obj * 0.6], cams, radius=1.0)
    assert not removed and len(kept) == 600


def test_fit_export_eval_on_a_phone_capture(capture, tmp_path):
    """The whole path as a user runs it: no masks given, mixed views, distortion."""
    cap = tmp_path / "cap"
    shutil.copytree(capture, cap)
    runner = CliRunner()
    out = tmp_path / "s.doodle"
    r = runner.invoke(cli, ["fit", str(cap), "-o", str(out), "--size", "160", "--evidence-size", "160",
                            "--evidence-voxels", "96", "--sq-iterations", "60"])
    assert r.exit_code == 0, r.output
    assert "automatic masks" in r.output and (cap / "doodle-masks").is_dir()
    r = runner.invoke(cli, ["export", str(out), "-o", str(tmp_path / "views"), "--cameras", str(cap), "--png",
                            "--no-svg"])
    assert r.exit_code == 0, r.output
    sizes = {Image.open(p).size for p in (tmp_path / "views").glob("*.png")}
    assert sizes == {(160, 120), (120, 160)}  # each dataset camera at its own size and orientation
    r = runner.invoke(cli, ["export", str(out), "-o", str(tmp_path / "orbit"), "--views", "2", "--png", "--no-svg"])
    assert r.exit_code == 0, r.output
    assert Image.open(tmp_path / "orbit" / "view_000.png").size == (160, 120)  # the photos' size, not 256
    r = runner.invoke(cli, ["eval", str(out), str(cap), "--size", "160", "--masks", str(cap / "true_masks"),
                            "--json", "-"])
    assert r.exit_code == 0, r.output
    import json

    m = json.loads(r.stdout)  # progress goes to stderr: stdout is JSON only
    assert m["views"] == 15 and m["silhouette_recall"] > 0.6 and m["line_precision"] > 0.6, m
    # the same as a folder of photos whose SfM model is cached: still JSON only on stdout
    photos = tmp_path / "photos"
    shutil.copytree(cap / "images", photos)
    import pycolmap

    (photos / ".doodle-sfm" / "model").mkdir(parents=True)
    pycolmap.Reconstruction(str(cap / "sparse" / "0")).write_binary(str(photos / ".doodle-sfm" / "model"))
    r = runner.invoke(cli, ["eval", str(out), str(photos), "--size", "160", "--masks", str(cap / "true_masks"),
                            "--json", "-"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["views"] == 15 and "reusing" in r.stderr


def test_bad_captures_get_one_line_errors(tmp_path, capture):
    runner = CliRunner()
    two = tmp_path / "two"
    two.mkdir()
    for k in range(2):
        Image.new("RGB", (32, 32), (k * 90, 20, 20)).save(two / f"p{k}.jpg")
    r = runner.invoke(cli, ["fit", str(two), "-o", str(tmp_path / "x.doodle")])
    assert r.exit_code == 2 and "needs at least 3 photos, found 2" in r.output
    missing = tmp_path / "missing"
    shutil.copytree(capture, missing)
    next((missing / "images").glob("*.jpg")).unlink()
    r = runner.invoke(cli, ["fit", str(missing), "-o", str(tmp_path / "x.doodle")])
    assert r.exit_code == 2 and "image not found" in r.output and "Traceback" not in r.output
    fisheye = tmp_path / "fisheye"
    shutil.copytree(capture, fisheye)
    cams = fisheye / "sparse/0/cameras.txt"
    cams.write_text(cams.read_text().replace("SIMPLE_RADIAL", "SIMPLE_RADIAL_FISHEYE"))
    with pytest.raises(SceneError, match="fisheye"):
        load_scene(fisheye)
    r = runner.invoke(cli, ["fit", str(capture), "-o", str(tmp_path / "x.doodle"), "--masks", str(tmp_path / "nope")])
    assert r.exit_code == 2 and "mask folder not found" in r.output


def test_photos_that_do_not_overlap_fail_cleanly(tmp_path):
    rng = np.random.default_rng(0)
    for k in range(3):
        Image.fromarray((rng.random((96, 128, 3)) * 255).astype(np.uint8)).save(tmp_path / f"p{k}.jpg")
    r = CliRunner().invoke(cli, ["fit", str(tmp_path), "-o", str(tmp_path / "x.doodle")])
    assert r.exit_code == 2 and "structure-from-motion failed" in r.output, r.output


def test_misaimed_cameras_are_flagged():
    """Cameras on a ring aimed at the object, two aimed 10° off (SfM put them on the wrong side): flagged;
    a forward-facing capture (parallel axes) flags nothing."""
    from doodle.scenes.photos import misaimed

    rng = np.random.default_rng(0)
    a = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    centres = np.stack([4 * np.cos(a), 4 * np.sin(a), 1 + 0.3 * rng.standard_normal(24)], 1)
    aim = rng.normal(scale=0.05, size=(24, 3))  # roughly centred, as by hand
    directions = aim - centres
    off = np.radians(10)
    for k in (3, 17):  # turn two cameras about the vertical axis
        c, s = np.cos(off), np.sin(off)
        directions[k] = [c * directions[k, 0] - s * directions[k, 1], s * directions[k, 0] + c * directions[k, 1],
                         directions[k, 2]]
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    assert np.flatnonzero(misaimed(centres, directions)).tolist() == [3, 17]
    directions[[3, 17]] = -centres[[3, 17]] / np.linalg.norm(centres[[3, 17]], axis=1, keepdims=True)
    assert not misaimed(centres, directions).any()
    forward = np.tile([0.0, 0.0, 1.0], (10, 1))
    assert not misaimed(np.c_[np.arange(10.0), np.zeros(10), np.zeros(10)], forward).any()


def test_a_point_floating_off_the_object_is_not_an_object_point(capture):
    """A chance match floating beside the object (within its reach, but alone) would seed every view's cut."""
    from dataclasses import replace

    from doodle.scenes.automask import object_points

    scene = load_colmap(capture)
    r = scene.frame.radius
    rng = np.random.default_rng(0)
    body = scene.frame.center + rng.uniform(-0.3 * r, 0.3 * r, (3000, 3))  # an object's dense SfM points
    floating = scene.frame.center + np.array([0.0, 0.0, 0.5 * r])
    found = object_points(replace(scene, points=np.vstack([body, floating])))
    assert not np.any(np.all(np.isclose(found, floating), axis=1))
    assert len(found) >= 0.95 * len(body)  # the object's own points stay
